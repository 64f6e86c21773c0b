#!/usr/bin/env python3
"""Writes the seed corpora of the image and mesh harnesses (tests/fuzz/corpus): a small valid file
in every format, with the harness's selector byte first. The scene seeds are real scenes; the model
seeds are the files of fuzz_model's own model, with their selector byte (run a replay of it with
SINEW_FUZZ_KEEP_SCRATCH=1 and take them from /tmp/sinew-fuzz-PID/pristine; docs/reliability.md)."""
import gzip, os, struct, sys

here = os.path.dirname(os.path.abspath(__file__))

def put(harness, name, selector, data):
    folder = os.path.join(here, "corpus", harness)
    os.makedirs(folder, exist_ok=True)
    with open(os.path.join(folder, name), "wb") as f:
        f.write(bytes([selector]) + data)

# A 4x3x2 float image, voxel value = its index.
nx, ny, nz = 4, 3, 2
voxels = struct.pack("<%df" % (nx * ny * nz), *range(nx * ny * nz))

def nifti():
    h = bytearray(348)
    struct.pack_into("<i", h, 0, 348)
    struct.pack_into("<8h", h, 40, 3, nx, ny, nz, 1, 1, 1, 1)
    struct.pack_into("<hh", h, 70, 16, 32)            # datatype float32, bitpix
    struct.pack_into("<8f", h, 76, 1, 1.0, 1.5, 2.0, 1, 1, 1, 1)
    struct.pack_into("<f", h, 108, 352.0)             # vox_offset
    struct.pack_into("<f", h, 112, 1.0)               # scl_slope
    struct.pack_into("<hh", h, 252, 0, 1)             # qform (unknown), sform scanner
    struct.pack_into("<4f", h, 280, -1.0, 0, 0, 10)   # srow_x
    struct.pack_into("<4f", h, 296, 0, -1.5, 0, 20)
    struct.pack_into("<4f", h, 312, 0, 0, 2.0, 30)
    h[344:348] = b"n+1\0"
    return bytes(h) + b"\0\0\0\0" + voxels

nrrd_fields = (b"type: float\ndimension: 3\nspace: left-posterior-superior\nsizes: 4 3 2\n"
               b"space directions: (1,0,0) (0,1.5,0) (0,0,2)\nspace origin: (10,20,30)\n")
meta_fields = (b"ObjectType = Image\nNDims = 3\nBinaryData = True\nBinaryDataByteOrderMSB = False\n"
               b"Offset = 10 20 30\nTransformMatrix = 1 0 0 0 1 0 0 0 1\nElementSpacing = 1 1.5 2\n"
               b"DimSize = 4 3 2\nElementType = MET_FLOAT\n")
# Selectors as in fuzz_image.cpp: nii, nii.gz, nrrd, mha, nhdr, mhd.
put("image", "float.nii", 0, nifti())
put("image", "float.nii.gz", 1, gzip.compress(nifti(), mtime=0))
put("image", "raw.nrrd", 2, b"NRRD0004\n" + nrrd_fields + b"encoding: raw\nendian: little\n\n" + voxels)
put("image", "gzip.nrrd", 2, b"NRRD0004\n" + nrrd_fields + b"encoding: gzip\nendian: little\n\n"
    + gzip.compress(voxels, mtime=0))
put("image", "float.mha", 3, meta_fields + b"ElementDataFile = LOCAL\n" + voxels)
put("image", "detached.nhdr", 4, b"NRRD0004\n" + nrrd_fields + b"encoding: raw\nendian: little\n"
    b"data file: image.raw\n\0" + voxels)
put("image", "detached.mhd", 5, meta_fields + b"ElementDataFile = image.raw\n\0" + voxels)

# An octahedron, outward counter-clockwise.
pts = [(1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1), (0, 0, -1)]
tris = [(0, 2, 4), (2, 1, 4), (1, 3, 4), (3, 0, 4), (2, 0, 5), (1, 2, 5), (3, 1, 5), (0, 3, 5)]
def fmt(v): return " ".join("%g" % x for x in v)
vtp = ('<?xml version="1.0"?>\n<VTKFile type="PolyData" version="0.1" byte_order="LittleEndian">\n'
       '<PolyData><Piece NumberOfPoints="6" NumberOfPolys="8">\n'
       '<Points><DataArray type="Float32" NumberOfComponents="3" format="ascii">'
       + " ".join(fmt(p) for p in pts) + '</DataArray></Points>\n'
       '<Polys><DataArray type="Int64" Name="connectivity" format="ascii">'
       + " ".join(fmt(t) for t in tris) + '</DataArray>\n'
       '<DataArray type="Int64" Name="offsets" format="ascii">'
       + " ".join(str(3 * (i + 1)) for i in range(8)) + '</DataArray></Polys>\n'
       '</Piece></PolyData></VTKFile>\n').encode()
vtk = ("# vtk DataFile Version 3.0\noctahedron\nASCII\nDATASET POLYDATA\nPOINTS 6 float\n"
       + "\n".join(fmt(p) for p in pts) + "\nPOLYGONS 8 32\n"
       + "\n".join("3 " + fmt(t) for t in tris) + "\n").encode()
def normal(t):
    a, b, c = (pts[i] for i in t)
    u = [b[k] - a[k] for k in range(3)]; v = [c[k] - a[k] for k in range(3)]
    return (u[1]*v[2]-u[2]*v[1], u[2]*v[0]-u[0]*v[2], u[0]*v[1]-u[1]*v[0])
stl = ("solid octahedron\n" + "".join(
    "facet normal %s\n outer loop\n%s endloop\nendfacet\n" % (fmt(normal(t)), "".join("  vertex %s\n" % fmt(pts[i]) for i in t))
    for t in tris) + "endsolid octahedron\n").encode()
stl_binary = b"\0" * 80 + struct.pack("<I", len(tris)) + b"".join(
    struct.pack("<12fH", *normal(t), *[x for i in t for x in pts[i]], 0) for t in tris)
obj = ("".join("v %s\n" % fmt(p) for p in pts) + "".join("f %d %d %d\n" % tuple(i + 1 for i in t) for t in tris)).encode()
ply = ("ply\nformat ascii 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\n"
       "element face 8\nproperty list uchar int vertex_indices\nend_header\n"
       + "".join(fmt(p) + "\n" for p in pts) + "".join("3 " + fmt(t) + "\n" for t in tris)).encode()
# Selectors as in fuzz_mesh.cpp: vtp, vtk, stl, obj, ply, exact vtp.
put("mesh", "octahedron.vtp", 0, vtp)
put("mesh", "octahedron.vtk", 1, vtk)
put("mesh", "octahedron.stl", 2, stl)
put("mesh", "binary.stl", 2, stl_binary)
put("mesh", "octahedron.obj", 3, obj)
put("mesh", "octahedron.ply", 4, ply)
put("mesh", "exact.vtp", 5, vtp)

// Mesh files checked or read before VTK's readers would see them (found by fuzz_mesh;
// docs/reliability.md): VTK's PLY reader crashes on malformed headers and data, so PLY files are
// read here, strictly; VTK's STL reader allocates whatever triangle count a binary header claims,
// so that count must fit the file first; VTK's XML reader allocates what a VTP header claims, so
// the claims must fit the file first too.
#pragma once

#include "sinew/core/triangle_mesh.h"

#include <filesystem>

namespace sinew {

// A PLY file (ascii, binary little or big endian): the vertex element's x, y, z and the face
// element's polygons (triangulated as fans). Throws InputError naming the file, the line or item,
// and the problem: unknown keywords or types, counts that do not fit the file, indices out of
// range, data that ends early.
TriangleMesh readPly(const std::filesystem::path& path);

// A binary STL's triangle count must fit its size (84 + 50 bytes per triangle); an ASCII STL
// starts with "solid". Throws InputError naming the file otherwise.
void checkStlSize(const std::filesystem::path& path);

// A VTK XML file (.vtp): a piece's element counts must fit the file, and each raw appended array's
// block header must fit it and claim no more than its blocks can hold (zlib: 1032:1), since VTK
// allocates these sizes before reading the data. Other encodings are left to VTK. Throws InputError
// naming the file, the array and the problem (vtk_xml_checks.cpp).
void checkVtkXmlSizes(const std::filesystem::path& path);

}  // namespace sinew

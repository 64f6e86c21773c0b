// Which of a NIfTI file's two placements Sinew reads, shared by the image IO plugin and
// sinew-make-subject (both read through ITK).
//
// A NIfTI header may place its voxels twice: the qform (a rotation) and the sform (an affine).
// Where both are set and differ, ITK 5.2 takes the qform, unless the sform's code is
// NIFTI_XFORM_SCANNER_ANAT. FSL, nibabel and MRIcron take the sform. The atlases of mricron-data
// (JHU white matter, Harvard-Oxford, AICHA) hold a qform flipped or displaced against their sform:
// read by the qform they lie outside every image in MNI space. So where the sform is a rotation or
// a reflection times the voxel size ITK read, Sinew takes it; otherwise (no sform, or one with a
// shear or another voxel size) ITK's placement stays.
#pragma once

#include <itkMatrix.h>
#include <itkPoint.h>
#include <itkVector.h>
#include <nifti1_io.h>

#include <cmath>
#include <optional>
#include <string>

namespace sinew::nifti {

struct Placement {
  itk::Point<double, 3> origin;       // LPS millimetres
  itk::Matrix<double, 3, 3> direction;  // columns: the voxel axes in LPS
};

// The placement path's sform gives, for voxels of `spacing`, where it differs from ITK's `read`
// (by more than 1e-3 mm or 1e-4 in a direction); nullopt: keep ITK's, to the bit.
inline std::optional<Placement> sformPlacement(const std::string& path, const itk::Vector<double, 3>& spacing,
                                               const Placement& read) {
  nifti_image* header = nifti_image_read(path.c_str(), 0);  // the header only
  if (!header) return std::nullopt;
  const int code = header->sform_code;
  const mat44 m = header->sto_xyz;
  nifti_image_free(header);
  if (code <= 0) return std::nullopt;
  const double lps[3] = {-1.0, -1.0, 1.0};  // RAS in the file, LPS inside
  Placement p;
  for (int c = 0; c < 3; ++c) {
    double length = 0.0;
    for (int r = 0; r < 3; ++r) length += double(m.m[r][c]) * double(m.m[r][c]);
    length = std::sqrt(length);
    if (!(std::abs(length - spacing[c]) <= 1e-4 * spacing[c])) return std::nullopt;
    for (int r = 0; r < 3; ++r) p.direction[r][c] = lps[r] * double(m.m[r][c]) / length;
  }
  for (int a = 0; a < 3; ++a)
    for (int b = 0; b < 3; ++b) {
      double dot = 0.0;
      for (int r = 0; r < 3; ++r) dot += p.direction[r][a] * p.direction[r][b];
      if (!(std::abs(dot - (a == b ? 1.0 : 0.0)) <= 1e-4)) return std::nullopt;
    }
  for (int r = 0; r < 3; ++r) p.origin[r] = lps[r] * double(m.m[r][3]);
  bool differs = false;
  for (int r = 0; r < 3; ++r) {
    differs |= !(std::abs(p.origin[r] - read.origin[r]) <= 1e-3);
    for (int c = 0; c < 3; ++c) differs |= !(std::abs(p.direction[r][c] - read.direction[r][c]) <= 1e-4);
  }
  if (!differs) return std::nullopt;
  return p;
}

}  // namespace sinew::nifti

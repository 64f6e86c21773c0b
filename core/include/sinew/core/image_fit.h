// How well the image agrees with a surface where it now lies, vertex by vertex: a run without a
// ground truth has no other measure of a wrong result (a model placed on the wrong edges by a bad
// initialisation converges and exits 0). A force offers it by also deriving from ImageFit, as a
// force offers its CUDA path by deriving from cuda::DeviceForce; Force itself is unchanged, so
// plugins built against the SDK keep their layout.
#pragma once

#include "sinew/core/force.h"

#include <limits>
#include <span>
#include <vector>

namespace sinew {

// Below this, a structure's image fit (StructureResult::imageFit: its mean match with the noise
// taken out, 1 where the image looks as trained) makes sinew-run and the cohort report say
// "check". Over 30 generated subjects of every kind of image, correctly placed, every structure
// scored 0.89 or more; placed 6-10 mm off, most structures that ended over 2 mm off scored below it
// (docs/accuracy.md, "The image fit").
inline constexpr double kPoorImageFit = 0.6;
// vertexImageFit's smoothing passes (docs/accuracy.md, "The image fit point by point").
inline constexpr int kImageFitPasses = 16;

class ImageFit {
public:
  virtual ~ImageFit() = default;
  // For every vertex of every structure whose weight is positive (the others are left as they
  // are), at the current positions: match[v], how well the image there agrees with what was
  // trained (an NCC: 1 at best); agreement[v], how well it agrees with itself at a place nearby
  // whose noise is independent of the vertex's (an NCC too: near 1 where the image is clean, lower
  // the more of it is noise; the intensity profile takes parallel lines 2 voxels away).
  virtual void fitScores(ForceContext& ctx, std::span<float> match, std::span<float> agreement) = 0;
};

class Simulation;

// A structure's image fit: the means over its vertices of match and agreement, and
// fit = min(1, match / sqrt(agreement)), the match with the image's noise taken out (Spearman's
// correction for attenuation). Capped at 1: in noisy or coarse images a line shares less with its
// parallels than with itself, which would put the fit of a right surface above 1. NaN where no force
// offers one.
struct StructureImageFit {
  double match = std::numeric_limits<double>::quiet_NaN();
  double agreement = std::numeric_limits<double>::quiet_NaN();
  double fit = std::numeric_limits<double>::quiet_NaN();
};

// Every structure's image fit at the simulation's current positions, from the first force of the
// scene that offers one and is weighted above 0 on some structure. Costs a few
// profiles per vertex: call it on request (the end of a run, a button), not per step.
std::vector<StructureImageFit> imageFitOf(Simulation& sim);

// Where a structure fits the image and where not: per vertex, the same fit from the match smoothed
// over the surface (`passes` times each vertex the mean of itself and its three neighbours: one
// vertex's NCC is mostly noise), over the square root of its structure's mean agreement, capped at
// 1. The workstation colours the surfaces with it (View > Show Image Fit) and sinew-run writes it
// with the meshes (point data "image_fit"), to show where to correct. NaN where no force offers one.
std::vector<float> vertexImageFit(Simulation& sim, int passes = kImageFitPasses);

// Both from one scoring of the vertices (what each of the two above costs).
struct ImageFitScores {
  std::vector<StructureImageFit> structures;  // imageFitOf's
  std::vector<float> vertices;                // vertexImageFit's
};
ImageFitScores imageFitScores(Simulation& sim, int passes = kImageFitPasses);

}  // namespace sinew

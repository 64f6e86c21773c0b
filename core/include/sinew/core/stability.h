// The stability guard's settings and what it records (used by Simulation, scenes and reports).
#pragma once

#include <string>

namespace sinew {

// The stability guard checks every step, for every integrator: a non-finite position, or a vertex
// moving farther than maxStepMm in one step, rolls the step back to the last good state and halves
// the integrator's "time_step" (at most maxRetries times in a row). When that does not help, step()
// throws NumericalError with the last good state in the store.
// The shape guard's limits (shape_guard.h): each structure against itself at the start of the
// simulation, at every report sample.
struct ShapeLimits {
  double minVolumeRatio = 0.5;       // volume / volume at the start
  double maxVolumeRatio = 2.0;
  double maxDriftMm = 10.0;          // centroid distance from the start
  // Vertices farther outside the target image than the structure reached at the start plus
  // outsideBandMm, as a share of its vertices (fewer than kMinOutside never count: small coarse
  // levels). A structure that a field of view cuts starts partly outside, and its vertices at the
  // cut cross the border by a millimetre or two as the surface fits. (Held instead to its share
  // outside at the start plus 1 %, AAL's SupraMarginal_L on a subject cut to 0.6 of the head's
  // height stopped the run going from 39.3 to 41.7 %.) One carried out of the image goes farther.
  double maxOutsideFraction = 0.01;
  static constexpr int kMinOutside = 5;
  double outsideBandMm = 2.0;
  // Cells (faces of the simplex mesh) turned over against their orientation at the start, and
  // cells collapsed below a hundredth of their area at the start, as shares of the structure's
  // cells. Fine levels of thin structures fold a few per cent of their cells locally (the
  // hippocampus at level 4: 2 %) without being wrong as a whole.
  double maxInvertedFraction = 0.05;
  double maxCollapsedFraction = 0.05;
  // Sampled triangles of the surface (self_intersection.h) that cross another part of the same
  // surface, as a share of the sample; the same allowance as folded cells.
  double maxSelfIntersectingFraction = 0.05;
  // Vertices swinging at the end of a chunk, as a share of the structure's: each moved more than
  // kSwingStepMm in the last step, yet ended the chunk less than two such steps from where it
  // began it (back and forth, the signature of an explicit step too long for the contacts and the
  // shape prior together). The demo's few trembling light vertices stay under 4 %.
  double maxSwingingFraction = 0.1;
  static constexpr float kSwingStepMm = 0.25f;
  static constexpr int kMinSwinging = 10;  // fewer swinging vertices never count (small coarse levels)
};

struct StabilityGuard {
  bool enabled = true;
  double maxStepMm = 20.0;
  int maxRetries = 6;
  ShapeLimits shape;
};

struct StabilityEvent {
  long iteration = 0;
  int level = 0;
  std::string reason;     // what the check found, naming the structure and vertex
  double timeStep = 0.0;  // the step size after the event (halved), or the last one tried
  bool recovered = true;  // false: the guard gave up and the run stops here
};

}  // namespace sinew

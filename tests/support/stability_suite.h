// The stability suite (docs/stability.md): stiff and extreme cases, each run for each integrator
// at step sizes relative to the explicit limit, classified as stable, rolled back or failed
// cleanly. Shared by tst_stability (acceptance) and bench_stability (the full matrix, the
// stability map and the tables in the docs).
#pragma once

#include "sinew/core/simulation.h"

#include <functional>
#include <string>
#include <vector>

namespace sinew::testing {

struct StabilityCase {
  std::string name;
  std::string description;
  // Adds structures, forces and images (the runner sets the integrator and its step).
  std::function<void(Simulation&)> build;
  // Mean distance (mm) of the final surface to the true one; NaN when the case has no answer.
  std::function<double(Simulation&)> errorMm;
  int iterations = 150;
  double vertexMass = 1.0;  // mean vertex mass (1: the engine's automatic density)
  bool stiff = false;  // internal forces at their maximum weight with light vertices
  bool large = false;  // >= 512^3 image: only in the full run
};

struct StabilityRun {
  std::string caseName, integrator;
  double timeStep = 0.0;       // asked for
  double finalTimeStep = 0.0;  // after the guard's halvings
  int rollbacks = 0;
  bool failed = false;         // the guard gave up (NumericalError)
  bool finite = true;          // every output position finite (must always hold)
  double errorMm = 0.0;
  double seconds = 0.0;
  std::string message;  // the guard's last reason, if any
  std::string outcome() const {
    if (!finite) return "NON-FINITE OUTPUT";
    return failed ? "failed cleanly" : rollbacks > 0 ? "rolled back" : "stable";
  }
};

std::vector<StabilityCase> stabilityCases(bool includeLarge);
// Runs `iterations` steps (the case's when 0) with the integrator at this step; the error is
// measured when asked (it costs more than a short run).
StabilityRun runStabilityCase(const StabilityCase& c, const std::string& integrator, double timeStep,
                              int iterations = 0, bool measureError = true);
// The largest step on a geometric grid (ratio 2^(1/4)) from `from` up to `to` for which the case
// runs without any rollback; 0 when even `from` needs one.
double largestStableStep(const StabilityCase& c, const std::string& integrator, double from, double to,
                         int iterations = 0);

// One cell of the stability map: a smooth sphere under smoothing + shape prior at weight 1, mean
// vertex mass `mass` (stiffness per mass ~ 2 / mass), image-free.
StabilityRun runStiffnessCell(const std::string& integrator, double timeStep, double mass, int iterations = 150);

}  // namespace sinew::testing

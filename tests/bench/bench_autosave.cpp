// The stability guard's and the autosave's cost to the frame loop (docs/reliability.md): the
// workstation's session stepped in frames of a fixed simulation budget, as its Run does, without
// the guard, with it, and with it and an autosave every second (what a user sees with changes at
// every frame: the worst case), side by side in one run, each phase from the same state. Reports the
// frame time's median, 99th percentile and maximum, and the autosave's copy on the frame's thread
// (its writing runs on a thread of its own); first, one shape check's own cost at this size.
//   bench_autosave SCENE [--level 5] [--backend auto] [--seconds 10] [--budget-ms 16]
//                  [--max-self-intersecting-fraction F]
#include "builtin_plugins.h"
#include "segmentation_session.h"
#include "session_recovery.h"
#include "sinew/core/self_intersection.h"
#include "sinew/core/shape_guard.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>

using namespace sinew;
using Clock = std::chrono::steady_clock;

namespace {
double since(Clock::time_point t) { return std::chrono::duration<double>(Clock::now() - t).count(); }

void report(const char* what, std::vector<double> frames, const std::string& extra) {
  std::sort(frames.begin(), frames.end());
  const auto at = [&](double q) { return 1e3 * frames[std::min(frames.size() - 1, std::size_t(q * frames.size()))]; };
  std::printf("| %s | %zu | %.2f | %.2f | %.2f | %s |\n", what, frames.size(), at(0.5), at(0.99), 1e3 * frames.back(),
              extra.c_str());
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"bench_autosave: the autosave's cost to the frame loop"};
  std::string scene, backend = "auto";
  int level = 5;
  double seconds = 10.0, budgetMs = 16.0;
  cli.add_option("scene", scene)->required()->check(CLI::ExistingFile);
  cli.add_option("--level", level)->capture_default_str();
  cli.add_option("--backend", backend)->check(CLI::IsMember({"auto", "cuda", "cpu"}))->capture_default_str();
  cli.add_option("--seconds", seconds, "per phase")->capture_default_str();
  cli.add_option("--budget-ms", budgetMs, "simulation per frame")->capture_default_str();
  double selfLimit = -1.0;
  cli.add_option("--max-self-intersecting-fraction", selfLimit,
                 "the guard's self-intersection limit for the phases (default: the scene's); the check runs in full either way");
  CLI11_PARSE(cli, argc, argv);

  Registry registry;
  registerBuiltinPlugins(registry);
  SegmentationSession session(registry);
  SessionOpenOptions options;
  options.backend = backend;
  // The guard's rollbacks, as the workstation's log shows them: each with its time in the phase.
  auto phaseStart = Clock::now();
  int logged = 0;
  options.log = [&](const std::string& line) {
    if (++logged <= 20) std::printf("  [%.2f s] %s\n", since(phaseStart), line.c_str());
  };
  session.open(scene, options);
  // Through the levels as a run goes: each level's planned steps before the next (entered directly,
  // the finest levels of the big scene fold within a few steps).
  while (session.level() < level) {
    session.step(session.levelIterationsPlanned());
    if (!session.nextLevel()) break;
  }
  session.setParameter("smoothing", -1, "weight", session.parameter("smoothing", 0, "weight"));  // one undo step
  std::printf("%ld vertices at level %d, backend %s (%s)\n\n", long(session.simulation().store().vertexCount()),
              session.level(), session.backendName().c_str(), session.deviceName().c_str());
  const SessionState start = session.state();  // also brings the host's copy of the state up to date

  // One shape check (shape_guard.h) on the host at this size, every structure, and the
  // self-intersection sampling alone; the image is made large enough to hold every vertex.
  {
    MeshStore& store = session.simulation().store();
    ImageGeometry everywhere;
    everywhere.size = {40000, 40000, 40000};
    everywhere.origin = Eigen::Vector3d(-20000, -20000, -20000);
    ShapeGuard shape;
    shape.capture(store, everywhere);
    std::vector<std::string> names(std::size_t(store.meshCount()), "s");
    std::vector<double> check, self;
    for (int r = 0; r < 11; ++r) {
      auto c0 = Clock::now();
      const std::string problem = shape.check(store, everywhere, StabilityGuard{}.shape, names);
      check.push_back(since(c0));
      c0 = Clock::now();
      for (Index m = 0; m < store.meshCount(); ++m) sampleSelfIntersections(store, store.positions(), m);
      self.push_back(since(c0));
      if (r == 0 && !problem.empty()) std::printf("(the check finds: %s)\n", problem.c_str());
    }
    std::sort(check.begin(), check.end());
    std::sort(self.begin(), self.end());
    std::printf("one shape check, every structure (parallel over structures): median %.2f ms; the self-intersection "
                "sampling alone, one structure after another: median %.2f ms (11 runs)\n\n",
                1e3 * check[5], 1e3 * self[5]);
  }

  const std::filesystem::path root = std::filesystem::temp_directory_path() / "sinew-bench-autosave";
  std::printf("| phase | frames | median ms | p99 ms | max ms | autosave |\n| --- | --- | --- | --- | --- | --- |\n");
  const StabilityGuard guard = session.simulation().stabilityGuard();
  for (const int phase : {0, 1, 2}) {  // guard off; the guard; the guard and the autosave
    const bool autosave = phase == 2;
    if (phase > 0) session.restoreState(start, options);
    StabilityGuard g = guard;
    g.enabled = phase > 0;
    if (selfLimit >= 0.0) g.shape.maxSelfIntersectingFraction = selfLimit;
    session.simulation().setStabilityGuard(g);
    std::unique_ptr<SessionRecovery> recovery;
    if (autosave) recovery = std::make_unique<SessionRecovery>(root);
    std::vector<double> frames;
    const auto t0 = Clock::now();
    phaseStart = t0;
    logged = 0;
    std::string stopped;
    while (since(t0) < seconds && stopped.empty()) {
      const auto f0 = Clock::now();
      try {
        session.stepFor(budgetMs * 1e-3, false);
      } catch (const NumericalError& e) {
        stopped = e.what();  // the stability guard gave up: the frame loop stops, as Run does
      }
      if (recovery) recovery->maybeSave(session, 1.0);
      frames.push_back(since(f0));
    }
    if (!stopped.empty()) std::printf("(the stability guard stopped the run: %s)\n", stopped.c_str());
    std::string extra = "off";
    if (recovery) {
      recovery->wait();
      char s[160];
      std::snprintf(s, sizeof s, "%d saves, copy on the frame's thread max %.2f ms", recovery->savesCompleted(),
                    1e3 * recovery->maxCopySeconds());
      extra = s;
    }
    report(phase == 0 ? "no stability guard, no autosave" : phase == 1 ? "stability guard" : "stability guard and autosave (every 1 s)",
           std::move(frames), extra);
  }
  return 0;
}

// sinew-run: the headless engine. One scene (one subject) per run; machine-readable report;
// documented exit codes (see --help and docs/sinew-run.md).
#include "backend_choice.h"
#include "thread_limits.h"
#include "builtin_plugins.h"
#include "output_lock.h"
#include "report_writer.h"
#include "sinew/core/image_fit.h"
#include "sinew/core/scene_runner.h"

#include <CLI/CLI.hpp>
#include "offscreen_qt.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <future>
#include <thread>
#include <iostream>
#include <unistd.h>

namespace fs = std::filesystem;
using namespace sinew;

namespace {

enum ExitCode { kOk = 0, kInternal = 1, kUsage = 2, kBadInput = 3, kNumerical = 4 };

const char* kExitCodes =
    "Exit codes:\n"
    "  0  success\n"
    "  1  internal error (a bug: please report it)\n"
    "  2  bad command line\n"
    "  3  bad input: scene, image, mesh, label or plugin problem (the message names the file)\n"
    "  4  numerical failure: the stability guard could not recover (the outputs hold the last good meshes)\n";

// Progress on stderr: a bar redrawn in place on a terminal, a plain line every 10 % otherwise.
class ProgressPrinter {
public:
  explicit ProgressPrinter(bool quiet) : quiet_(quiet), tty_(::isatty(::fileno(stderr))) {}
  void operator()(const RunProgress& p) {
    if (quiet_ || p.total == 0) return;
    const int percent = static_cast<int>(100 * p.done / p.total);
    if (tty_) {
      const auto now = std::chrono::steady_clock::now();
      if (p.done != p.total && now - last_ < std::chrono::milliseconds(100)) return;
      last_ = now;
      const int width = 30, filled = width * percent / 100;
      std::fprintf(stderr, "\r[%s%s] %3d%%  level %d/%d  iteration %d/%d  %.2f s%s ", std::string(filled, '#').c_str(),
                   std::string(width - filled, ' ').c_str(), percent, p.level + 1, p.levelCount, p.iteration,
                   p.levelIterations, p.seconds, error(p).c_str());
      if (p.done == p.total) std::fputc('\n', stderr);
    } else if (percent / 10 != lastDecile_ || p.done == p.total) {
      lastDecile_ = percent / 10;
      std::fprintf(stderr, "progress %3d%%  level %d/%d  iteration %d/%d  %.2f s%s\n", percent, p.level + 1, p.levelCount,
                   p.iteration, p.levelIterations, p.seconds, error(p).c_str());
    }
    std::fflush(stderr);
  }

private:
  // The sample's mean error against the ground truth, where the scene has one (none at the last
  // sample: the end's exact evaluation, printed in the table after, scores it). On the terminal
  // blanks cover a longer text drawn before.
  std::string error(const RunProgress& p) {
    std::string text;
    if (std::isfinite(p.meanAssdMm) && std::isfinite(p.meanDice)) {
      char buffer[64];
      std::snprintf(buffer, sizeof buffer, "  mean ASSD %.3f mm  Dice %.3f", p.meanAssdMm, p.meanDice);
      text = buffer;
    }
    if (tty_) {
      const std::size_t drawn = text.size();
      text.resize(std::max(text.size(), errorWidth_), ' ');
      errorWidth_ = drawn;
    }
    return text;
  }

  bool quiet_, tty_;
  int lastDecile_ = -1;
  std::size_t errorWidth_ = 0;
  std::chrono::steady_clock::time_point last_{};
};

// NaN (no ground truth) prints as "-".
std::string cell(double v, int width, int precision = 3) {
  char b[32];
  if (std::isnan(v)) std::snprintf(b, sizeof b, "%*s", width, "-");
  else std::snprintf(b, sizeof b, "%*.*f", width, precision, v);
  return b;
}

void printTable(const RunReport& r) {
  // The name column fits the longest name (the JHU atlas has names of 40 characters and more).
  int w = 22;
  for (const StructureResult& s : r.structures) w = std::max(w, int(s.name.size()));
  if (!r.hasGroundTruth()) {
    // Without a ground truth the run reports how far it still moves and how hard it is pushed.
    std::printf("%-*s %9s %16s %12s %9s\n", w, "structure", "vertices", "displacement mm", "mean force", "image fit");
    const size_t n = r.structures.size();
    for (size_t i = 0; i < n && r.timeline.size() >= n; ++i) {
      const TimelineSample& t = r.timeline[r.timeline.size() - n + i];
      std::printf("%-*s %9d %16.4f %12.4f %s\n", w, r.structures[i].name.c_str(), r.structures[i].vertices,
                  t.meanDisplacementMm, t.meanForce, cell(r.structures[i].imageFit, 9).c_str());
    }
  } else {
    std::printf("%-*s %9s %11s %11s %10s %8s %8s %8s %9s\n", w, "structure", "vertices", "ASSD model", "ASSD start",
                "ASSD end", "Dice 0", "Dice", "HD95", "image fit");
    double sums[7] = {0, 0, 0, 0, 0, 0, 0};
    int n = 0;
    for (const StructureResult& s : r.structures) {
      std::printf("%-*s %9d %s %s %s %s %s %s %s\n", w, s.name.c_str(), s.vertices, cell(s.assdModelMm, 11).c_str(),
                  cell(s.assdInitialMm, 11).c_str(), cell(s.assdFinalMm, 10).c_str(), cell(s.diceInitial, 8).c_str(),
                  cell(s.dice, 8).c_str(), cell(s.hd95Mm, 8).c_str(), cell(s.imageFit, 9).c_str());
      if (std::isnan(s.assdFinalMm)) continue;
      const double v[7] = {s.assdModelMm, s.assdInitialMm, s.assdFinalMm, s.diceInitial, s.dice, s.hd95Mm, s.imageFit};
      for (int k = 0; k < 7; ++k) sums[k] += v[k];
      ++n;
    }
    if (n > 0)
      std::printf("%-*s %9s %s %s %s %s %s %s %s\n", w, "mean", "", cell(sums[0] / n, 11).c_str(), cell(sums[1] / n, 11).c_str(),
                  cell(sums[2] / n, 10).c_str(), cell(sums[3] / n, 8).c_str(), cell(sums[4] / n, 8).c_str(),
                  cell(sums[5] / n, 8).c_str(), cell(sums[6] / n, 9).c_str());
  }
  if (r.structures.size() > 1) {
    double before = 0.0, after = 0.0;
    int overlapping = 0;
    for (const OverlapResult& o : r.overlaps) {
      before += o.beforeMm3;
      after += o.afterMm3;
      overlapping += o.afterMm3 > 0.0;
    }
    std::printf("overlap between structures: %.1f mm^3 at the start, %.1f mm^3 at the end (%d pairs)\n", before, after,
                overlapping);
  }
  std::string past;
  for (const StructureResult& s : r.structures)
    if (s.outsideImageShare > 0.0) past += (past.empty() ? " " : ", ") + s.name + " " + cell(100.0 * s.outsideImageShare, 0, 1) + " %";
  if (!past.empty())
    std::printf("past the image's field of view (share of vertices):%s; there the model, not the image, shapes them\n",
                past.c_str());
  std::string poor;
  for (const StructureResult& s : r.structures)
    if (s.imageFit < kPoorImageFit) poor += (poor.empty() ? " " : ", ") + s.name + " " + cell(s.imageFit, 0, 2);
  if (!poor.empty())
    std::printf("check:%s: the image does not look as trained where these structures ended (image fit below %.2f; "
                "a wrong initialisation?)\n", poor.c_str(), kPoorImageFit);
  if (r.initialisation.method != "none") std::printf("initialisation: %s, %.2f s\n", r.initialisation.method.c_str(), r.initialisation.seconds);
  std::printf("backend %s, %s; simulation %.2f s, total %.2f s\n", r.backend.c_str(), r.device.c_str(),
              r.simulationSeconds, r.totalSeconds);
}

// Every output is written into a staging folder inside the output directory (which the run's
// OutputLock created and holds) and moved into place only when all of them were written, so a
// failed run leaves no partial outputs.
class Staging {
public:
  explicit Staging(const fs::path& out) : out_(out) {
    dir_ = out_ / (".sinew-staging-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
  }
  ~Staging() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }
  fs::path file(const std::string& name) {
    names_.push_back(name);
    return dir_ / name;
  }
  void commit() {
    // Anything that would stop a rename is found before the first file moves.
    for (const auto& n : names_)
      if (fs::is_directory(out_ / n)) throw InputError((out_ / n).string() + ": a directory is in the way of an output");
    for (const auto& n : names_) fs::rename(dir_ / n, out_ / n);
  }

private:
  fs::path out_, dir_;
  std::vector<std::string> names_;
};

void printParams(const std::vector<ParamDecl>& params) {
  for (const auto& p : params)
    std::printf("      %-18s default %-8g [%g, %g] %-3s %s%s\n", p.name.c_str(), p.defaultValue, p.min, p.max,
                p.unit.c_str(), p.help.c_str(), p.perStructure ? "" : " (shared by all structures)");
}

// Every plugin with its components and their parameters (from the parameter declarations).
void listPlugins(const PluginLoader& loader, const Registry& registry) {
  std::printf("plugin search path:");
  for (const auto& d : loader.searchPath()) std::printf(" %s", d.c_str());
  std::printf("\n");
  for (const PluginRecord& p : loader.plugins()) {
    std::printf("plugin %s %s (%s, %s): %s\n", p.name.c_str(), p.version.c_str(), pluginKindName(p.kind),
                p.file.empty() ? "built in" : p.file.c_str(), p.summary.c_str());
    if (p.kind == PluginKind::Tool) std::printf("    (an interaction tool: used by the workstation)\n");
    for (const PluginComponent& c : p.components) {
      const char* name = c.name.c_str();
      if (c.kind == PluginKind::Force) {
        std::printf("    force %s: %s\n", name, registry.force(c.name).summary.c_str());
        printParams(registry.force(c.name).params);
      } else if (c.kind == PluginKind::Integrator) {
        std::printf("    integrator %s: %s\n", name, registry.integrator(c.name).summary.c_str());
        printParams(registry.integrator(c.name).params);
      } else {
        std::printf("    %s %s\n", pluginKindName(c.kind), name);
      }
    }
  }
  for (const PluginFailure& f : loader.failures()) std::printf("not loaded: %s\n", f.message.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  const auto processStart = std::chrono::steady_clock::now();
  CLI::App cli{"sinew-run: segment one subject with the deformable models a scene file describes."};
  cli.footer(kExitCodes);
  std::string scenePath, outDir = "sinew-output";
  int threads = 0;
  bool quiet = false, list = false, verbose = false;
  std::string backendChoice = "auto";
  cli.add_option("scene", scenePath, "scene file (JSON)");
  cli.add_option("-o,--out", outDir, "output directory (created if missing)")->capture_default_str();
  cli.add_option("-j,--threads", threads, "CPU threads (0 = all)")->check(CLI::NonNegativeNumber);
  cli.add_flag("-q,--quiet", quiet, "no progress output");
  cli.add_flag("-v,--verbose", verbose, "print the wall time of every stage at the end (as in report.json's stage_seconds)");
  cli.add_option("--backend", backendChoice, "auto: CUDA when a usable GPU exists, else the CPU")
      ->check(CLI::IsMember({"auto", "cuda", "cpu"}))
      ->capture_default_str();
  cli.add_flag("--list-plugins", list,
               "list the built-in plugins and every plugin on the search path (SINEW_PLUGIN_PATH, "
               "~/.local/share/sinew/plugins, the installed plugin directory) with versions and parameters");
  cli.set_version_flag("--version", std::string("sinew-run ") + SINEW_VERSION);
  try {
    cli.parse(argc, argv);
    if (!list && scenePath.empty()) throw CLI::RequiredError("scene");
  } catch (const CLI::ParseError& e) {
    const int code = cli.exit(e);
    return code == 0 ? kOk : kUsage;
  }

  limitLibraryThreads(threads);  // before anything reads an image
  const auto qt = startOffscreenQt(argv[0]);  // the plot needs fonts

  Registry registry;
  PluginLoader plugins(registry);
  addBuiltinPlugins(plugins);
  if (list) {
    plugins.loadAll();
    listPlugins(plugins, registry);
    return kOk;
  }
  try {
    SceneDesc scene = readScene(scenePath);
    // Only the run-time plugins the scene names are loaded.
    for (std::size_t i = 0; i < scene.plugins.size(); ++i) {
      const PluginRecord* loaded = nullptr;
      try {
        loaded = &plugins.load(scene.plugins[i]);
      } catch (const InputError& e) {
        throw InputError(scenePath + ": /plugins/" + std::to_string(i) + ": " + e.what());
      }
      const PluginRecord& p = *loaded;
      if (!quiet)
        std::fprintf(stderr, "plugin %s %s: %s\n", p.name.c_str(), p.version.c_str(),
                     p.file.empty() ? "built in" : ("loaded from " + p.file.string()).c_str());
    }
    ProgressPrinter progress(quiet);
    // The stages count from the process's start ("startup").
    RunOptions options{threads, std::ref(progress), {}, {}, processStart};
    if (!quiet) options.log = [](const std::string& m) { std::fprintf(stderr, "%s\n", m.c_str()); };
    // Falling back to the CPU is always announced when the CUDA backend was asked for explicitly.
    auto notice = [&](const std::string& m) {
      if (!quiet || backendChoice == "cuda") std::fprintf(stderr, "%s\n", m.c_str());
    };
    options.backend = [&](Simulation& sim) { return makeBackend(backendChoice, sim, notice); };
    // The device starts while the scene loads (with -j 1 nothing runs beside the stages).
    if (threads != 1) startDeviceEarly(backendChoice);
    const DeviceStartWait deviceStarted;  // whatever way main is left from here
    // The output directory is this run's from here on: a second run writing there is refused now,
    // not after the work, and what killed runs left in it is cleared.
    const OutputLock lock(outDir);
    if (lock.staleRemoved() && !quiet)
      std::fprintf(stderr, "removed %d staging folder(s) a killed run left in %s\n", lock.staleRemoved(), outDir.c_str());
    SceneRunner runner(registry, scene, options);
    if (!quiet) std::fprintf(stderr, "loading %s\n", scenePath.c_str());
    runner.load();
    RunReport report = runner.run();
    for (const auto& s : report.structures)
      for (const Vec3& p : s.surface.points)
        if (!p.allFinite()) throw NumericalError("structure '" + s.name + "' has a non-finite vertex; nothing was written");
    if (scene.thickness) {
      addThickness(report, Executor(threads));
      report.stageClock.lap("thickness");
    }
    Staging out(outDir);
    // The outputs are independent files: written at once (one after the other with -j 1); the
    // first failure, in this order, is the one reported.
    const bool atOnce = threads != 1 && std::thread::hardware_concurrency() > 1;
    std::vector<std::future<void>> writes;
    const std::launch policy = atOnce ? std::launch::async : std::launch::deferred;
    auto write = [&](std::function<void()> task) { writes.push_back(std::async(policy, std::move(task))); };
    if (scene.writeMeshes)
      for (const auto& s : report.structures) {
        const fs::path target = out.file(s.name + scene.meshFormat);
        write([&, target] { registry.meshIOFor(target).write(target, s.surface); });
      }
    const fs::path labels = out.file(scene.labelMapName), slices = out.file("slices.png");
    LabelVolume labelMap;
    write([&] {
      labelMap = runner.labelMap(report);
      auto picture = std::async(policy, [&] {
        writeSliceOverlay(slices, runner.simulation().scene().targetImage(), labelMap, scene);
      });
      registry.imageIOFor(labels).writeLabels(labels, labelMap);
      picture.get();
    });
    if (report.initialisation.hasAffine) {
      const fs::path tfm = out.file("subject-to-atlas.tfm");
      write([&, tfm] { registry.imageRegistration().writeTransform(tfm, report.initialisation.transform); });
    }
    const fs::path reportCsv = out.file("report.csv"), timelineCsv = out.file("timeline.csv"), plot = out.file("error_vs_time.png");
    write([&] {
      writeReportCsv(reportCsv, report);
      writeTimelineCsv(timelineCsv, report, scene);
      writeErrorPlot(plot, report, scene);
    });
    for (auto& w : writes) w.wait();
    for (auto& w : writes) w.get();
    // report.json cannot time its own writing: the stage ends here, and so does total_seconds
    // (process start to outputs written).
    report.stageClock.lap("write_outputs");
    report.totalSeconds = report.stageClock.total();
    writeReportJson(out.file("report.json"), report, scene, plugins.plugins());
    out.commit();
    printTable(report);
    if (verbose) {
      std::fflush(stdout);
      std::fprintf(stderr, "stage                 seconds   share\n");
      for (const auto& [name, seconds] : report.stageClock.stages())
        std::fprintf(stderr, "%-20s %8.3f  %5.1f %%\n", name.c_str(), seconds, 100.0 * seconds / report.totalSeconds);
      std::fprintf(stderr, "%-20s %8.3f\n", "total", report.totalSeconds);
      for (const auto& [name, seconds] : report.backgroundSeconds)
        std::fprintf(stderr, "  beside the stages: %s %.3f s\n", name.c_str(), seconds);
      std::fprintf(stderr, "level       set-up  seconds    steps   checks  rollbacks\n");
      for (const StageResult& st : report.stages)
        if (const auto& l = st.level)
          std::fprintf(stderr, "%-9s %8.3f %8.3f %8.3f %8.3f  %9d\n", st.name.c_str(), l->enter, st.seconds, l->steps,
                       l->checks, l->rollbacks);
    }
    if (!quiet) std::fprintf(stderr, "outputs in %s\n", outDir.c_str());
    for (const StabilityEvent& e : report.stability)
      if (e.recovered && !quiet)
        std::fprintf(stderr, "stability guard: iteration %ld: %s; time step halved to %g\n", e.iteration, e.reason.c_str(),
                     e.timeStep);
    if (!report.numericalFailure.empty()) {
      std::fprintf(stderr, "sinew-run: %s: %s (the outputs hold the last good meshes)\n",
                   report.shapeFailure ? "degraded" : "numerical failure", report.numericalFailure.c_str());
      return kNumerical;
    }
    return kOk;
  } catch (const InputError& e) {
    std::fprintf(stderr, "sinew-run: error: %s\n", e.what());
    return kBadInput;
  } catch (const NumericalError& e) {
    std::fprintf(stderr, "sinew-run: numerical failure: %s\n", e.what());
    return kNumerical;
  } catch (const fs::filesystem_error& e) {
    std::fprintf(stderr, "sinew-run: error: %s\n", e.what());
    return kBadInput;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "sinew-run: internal error: %s\n", e.what());
    return kInternal;
  }
}

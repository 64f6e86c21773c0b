// The stability suite in full (docs/stability.md): every case for each integrator at 1x, 5x and 10x
// of the largest stable Verlet step, the stability map (step size x stiffness per mass, per
// integrator), and, given a scene with ground truth (the Colin27 demo), ASSD against simulation
// time for Verlet and implicit Euler at their best stable steps. Writes CSV, Markdown and PNG
// files into --out. Exits 1 if any output position was ever non-finite.
#include "builtin_plugins.h"
#include "sinew/core/scene_runner.h"
#include "stability_suite.h"

#include <CLI/CLI.hpp>
#include <QGuiApplication>
#include <QImage>
#include <QPainter>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>

using namespace sinew;
using namespace sinew::testing;
namespace fs = std::filesystem;

namespace {
const char* kIntegrators[] = {"damped_verlet", "implicit_euler"};

QColor outcomeColour(const StabilityRun& r) {
  if (!r.finite) return QColor(0, 0, 0);
  if (r.failed) return QColor(214, 69, 65);
  return r.rollbacks > 0 ? QColor(240, 173, 78) : QColor(92, 184, 92);
}

bool runCases(const fs::path& out, bool large) {
  bool allFinite = true;
  std::ofstream csv(out / "cases.csv"), md(out / "cases.md");
  csv << "case,integrator,verlet_limit,factor,time_step,outcome,rollbacks,final_time_step,error_mm,seconds\n";
  md << "| case | Verlet limit | integrator | 1x | 5x | 10x |\n| --- | ---: | --- | --- | --- | --- |\n";
  for (const StabilityCase& c : stabilityCases(large)) {
    if (large != c.large && large) continue;  // --large runs only the large case
    const double limit = largestStableStep(c, "damped_verlet", 0.005, 50.0);
    for (const char* integrator : kIntegrators) {
      md << "| " << c.name << " | " << limit << " | " << integrator;
      for (double factor : {1.0, 5.0, 10.0}) {
        const StabilityRun r = runStabilityCase(c, integrator, std::max(limit, 0.005) * factor);
        allFinite = allFinite && r.finite;
        char cell[160];
        std::snprintf(cell, sizeof cell, "%s%s, %s mm, %.2f s", r.outcome().c_str(),
                      r.rollbacks ? (" (" + std::to_string(r.rollbacks) + ")").c_str() : "",
                      std::isnan(r.errorMm) ? "-" : QString::number(r.errorMm, 'f', 2).toStdString().c_str(), r.seconds);
        md << " | " << cell;
        csv << c.name << ',' << integrator << ',' << limit << ',' << factor << ',' << r.timeStep << ',' << r.outcome()
            << ',' << r.rollbacks << ',' << r.finalTimeStep << ',' << r.errorMm << ',' << r.seconds << '\n';
        std::fprintf(stderr, "%-22s %-15s %4.1fx dt %-8.4g %s\n", c.name.c_str(), integrator, factor, r.timeStep,
                     cell);
      }
      md << " |\n";
    }
  }
  return allFinite;
}

bool runMap(const fs::path& out) {
  const std::vector<double> masses{10, 1, 0.1, 0.01, 0.001};
  const std::vector<double> steps{0.05, 0.1, 0.2, 0.5, 1, 2, 5, 10, 20, 50};
  bool allFinite = true;
  std::ofstream csv(out / "stability_map.csv");
  csv << "integrator,vertex_mass,stiffness_per_mass,time_step,outcome,rollbacks\n";
  const int cell = 46, left = 120, top = 60, gap = 60;
  const int w = left + int(steps.size()) * cell + 20, h = top + int(masses.size()) * cell + 50;
  QImage image(2 * w + gap, h + 40, QImage::Format_RGB32);
  image.fill(Qt::white);
  QPainter p(&image);
  QFont font = p.font();
  font.setPixelSize(12);
  p.setFont(font);
  for (int g = 0; g < 2; ++g) {
    const int x0 = g * (w + gap);
    p.setPen(Qt::black);
    p.drawText(x0 + left, 25, QString(kIntegrators[g]) + ": smoothing + shape prior at weight 1");
    for (size_t i = 0; i < masses.size(); ++i) {
      p.setPen(Qt::black);
      p.drawText(QRect(x0, top + int(i) * cell, left - 8, cell), Qt::AlignRight | Qt::AlignVCenter,
                 QString("k/m %1").arg(2.0 / masses[i]));
      for (size_t j = 0; j < steps.size(); ++j) {
        const StabilityRun r = runStiffnessCell(kIntegrators[g], steps[j], masses[i]);
        allFinite = allFinite && r.finite;
        csv << kIntegrators[g] << ',' << masses[i] << ',' << 2.0 / masses[i] << ',' << steps[j] << ',' << r.outcome()
            << ',' << r.rollbacks << '\n';
        const QRect box(x0 + left + int(j) * cell, top + int(i) * cell, cell - 2, cell - 2);
        p.fillRect(box, outcomeColour(r));
        if (r.rollbacks) p.drawText(box, Qt::AlignCenter, QString::number(r.rollbacks));
      }
    }
    for (size_t j = 0; j < steps.size(); ++j)
      p.drawText(QRect(x0 + left + int(j) * cell, top + int(masses.size()) * cell, cell, 20), Qt::AlignCenter,
                 QString::number(steps[j]));
    p.drawText(x0 + left, top + int(masses.size()) * cell + 40, "time step");
  }
  p.drawText(10, h + 30, "green: stable; amber: rolled back by the guard (count), then ran at a halved step; red: failed "
                         "cleanly; black: non-finite output (never seen)");
  p.end();
  image.save(QString::fromStdString((out / "stability_map.png").string()));
  return allFinite;
}

struct Curve {
  std::string label;
  std::vector<std::pair<double, double>> points;  // simulation seconds, mean ASSD
  double finalAssd = 0, seconds = 0;
  int rollbacks = 0;
};

RunReport runScene(const Registry& registry, SceneDesc scene, const std::string& integrator, double dt, double scale,
                   int levels) {
  scene.integrator = integrator;
  scene.integratorParams = {{"time_step", dt}};
  scene.schedule.resize(std::min<size_t>(scene.schedule.size(), levels));
  for (auto& l : scene.schedule) l.iterations = std::max(1, int(std::lround(l.iterations * scale)));
  SceneRunner runner(registry, scene, RunOptions{});
  runner.load();
  return runner.run();
}

void runErrorAgainstTime(const fs::path& out, const fs::path& scenePath) {
  Registry registry;
  registerBuiltinPlugins(registry);
  const SceneDesc scene = readScene(scenePath);
  double baseDt = 0.5;
  for (const auto& [name, value] : scene.integratorParams)
    if (name == "time_step") baseDt = value;
  // Best stable step: the largest on a doubling grid whose first level runs without a rollback.
  std::map<std::string, double> best;
  for (const char* integrator : kIntegrators) {
    best[integrator] = 0.0;
    for (double dt = baseDt; dt <= 64.0 * baseDt; dt *= 2.0) {
      const RunReport r = runScene(registry, scene, integrator, dt, baseDt / dt, 1);
      std::fprintf(stderr, "%s dt %g: %zu guard events, %s\n", integrator, dt, r.stability.size(),
                   r.numericalFailure.empty() ? "completed" : "failed");
      if (!r.stability.empty() || !r.numericalFailure.empty()) break;
      best[integrator] = dt;
    }
  }
  std::vector<Curve> curves;
  std::ofstream csv(out / "error_vs_time.csv");
  csv << "integrator,time_step,simulation_seconds,mean_assd_mm\n";
  for (const char* integrator : kIntegrators) {
    const double dt = best[integrator];
    if (dt <= 0.0) continue;
    // The same simulated time as the scene's schedule at its own step.
    const RunReport r = runScene(registry, scene, integrator, dt, baseDt / dt, int(scene.schedule.size()));
    Curve c;
    c.label = std::string(integrator) + ", dt " + QString::number(dt).toStdString();
    std::map<double, std::pair<double, int>> bySecond;
    for (const TimelineSample& s : r.timeline) {
      auto& [sum, n] = bySecond[s.seconds];
      sum += s.assdMm;
      ++n;
    }
    for (const auto& [t, v] : bySecond) {
      c.points.push_back({t, v.first / v.second});
      csv << integrator << ',' << dt << ',' << t << ',' << v.first / v.second << '\n';
    }
    c.finalAssd = c.points.back().second;
    c.seconds = r.simulationSeconds;
    c.rollbacks = int(r.stability.size());
    std::fprintf(stderr, "%s: final mean ASSD %.3f mm after %.2f s of simulation\n", c.label.c_str(), c.finalAssd,
                 c.seconds);
    curves.push_back(c);
  }
  // The plot.
  const int W = 900, H = 520, left = 70, right = 30, top = 40, bottom = 60;
  double tMax = 1e-9, yMax = 1e-9;
  for (const Curve& c : curves)
    for (const auto& [t, y] : c.points) tMax = std::max(tMax, t), yMax = std::max(yMax, y);
  QImage image(W, H, QImage::Format_RGB32);
  image.fill(Qt::white);
  QPainter p(&image);
  p.setRenderHint(QPainter::Antialiasing);
  const QRectF plot(left, top, W - left - right, H - top - bottom);
  auto X = [&](double t) { return plot.left() + plot.width() * t / tMax; };
  auto Y = [&](double y) { return plot.bottom() - plot.height() * y / (1.05 * yMax); };
  p.setPen(Qt::black);
  p.drawRect(plot);
  for (int i = 0; i <= 5; ++i) {
    p.drawText(QPointF(X(tMax * i / 5) - 10, plot.bottom() + 18), QString::number(tMax * i / 5, 'f', 1));
    p.drawText(QPointF(8, Y(1.05 * yMax * i / 5) + 4), QString::number(1.05 * yMax * i / 5, 'f', 2));
  }
  p.drawText(QPointF(plot.center().x() - 60, H - 15), "simulation time (s)");
  p.drawText(QPointF(left, 25), "Colin27: mean ASSD (mm) against simulation time");
  const QColor colours[] = {QColor(31, 119, 180), QColor(214, 39, 40)};
  for (size_t k = 0; k < curves.size(); ++k) {
    p.setPen(QPen(colours[k % 2], 2));
    for (size_t i = 1; i < curves[k].points.size(); ++i)
      p.drawLine(QPointF(X(curves[k].points[i - 1].first), Y(curves[k].points[i - 1].second)),
                 QPointF(X(curves[k].points[i].first), Y(curves[k].points[i].second)));
    p.drawText(QPointF(plot.right() - 330, top + 20 + 18 * k),
               QString::fromStdString(curves[k].label) + QString(": %1 mm at %2 s").arg(curves[k].finalAssd, 0, 'f', 3).arg(curves[k].seconds, 0, 'f', 1));
  }
  p.end();
  image.save(QString::fromStdString((out / "error_vs_time.png").string()));
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"bench_stability: the stability suite, the stability map and error against time (docs/stability.md)"};
  std::string outDir = "stability-out", colin;
  bool large = false, skipCases = false, skipMap = false;
  cli.add_option("-o,--out", outDir, "output folder")->capture_default_str();
  cli.add_flag("--large", large, "run only the >= 512^3 image case");
  cli.add_flag("--skip-cases", skipCases, "skip the case table");
  cli.add_flag("--skip-map", skipMap, "skip the stability map");
  cli.add_option("--scene", colin, "a scene with ground truth for error against time (the Colin27 demo)");
  CLI11_PARSE(cli, argc, argv);
  qputenv("QT_QPA_PLATFORM", "offscreen");
  QGuiApplication app(argc, argv);
  fs::create_directories(outDir);
  bool finite = true;
  if (!skipCases) finite = runCases(outDir, large) && finite;
  if (!skipMap && !large) finite = runMap(outDir) && finite;
  if (!colin.empty()) runErrorAgainstTime(outDir, colin);
  if (!finite) std::fprintf(stderr, "bench_stability: a run produced a non-finite position\n");
  return finite ? 0 : 1;
}

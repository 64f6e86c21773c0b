// Drawn with QPainter on a QImage: needs a QGuiApplication (for fonts), which sinew-run creates on
// the offscreen platform, so no display is needed.
#include "pictures.h"
#include "report_writer.h"

#include <QColor>
#include <QFont>
#include <QImage>
#include <QPainter>
#include <QPainterPath>

#include <algorithm>
#include <cmath>
#include <functional>

namespace sinew {

namespace {
// One panel: a value of every structure's timeline against time, from yMin to yMax. With an
// initialisation, each structure's line starts with a dashed step from `before` (the model's
// placement) to `after` (the initialisation's) over the initialisation's time.
struct Panel {
  QRectF rect;
  double yMin, yMax;
  QString label;
  std::function<double(const TimelineSample&)> value;
  std::function<double(std::size_t)> before, after;  // empty without an initialisation
};

void drawPanel(QPainter& p, const Panel& panel, const RunReport& r, const SceneDesc& scene, double tMin, double tMax,
               bool timeLabels) {
  const QRectF& plot = panel.rect;
  auto X = [&](double s) { return plot.left() + plot.width() * (s - tMin) / (tMax - tMin); };
  auto Y = [&](double v) { return plot.bottom() - plot.height() * (v - panel.yMin) / (panel.yMax - panel.yMin); };
  const int ticks = plot.height() > 300 ? 5 : 4;
  p.setPen(QPen(QColor(220, 220, 220), 1));
  for (int i = 0; i <= ticks; ++i) {
    const double v = panel.yMin + (panel.yMax - panel.yMin) * i / ticks;
    p.drawLine(QPointF(plot.left(), Y(v)), QPointF(plot.right(), Y(v)));
    p.setPen(Qt::black);
    p.drawText(QRectF(0, Y(v) - 8, plot.left() - 8, 16), Qt::AlignRight | Qt::AlignVCenter, QString::number(v, 'f', 2));
    p.setPen(QPen(QColor(220, 220, 220), 1));
  }
  for (int i = 0; i <= 5; ++i) {
    const double s = tMin + (tMax - tMin) * i / 5;
    p.drawLine(QPointF(X(s), plot.top()), QPointF(X(s), plot.bottom()));
    if (!timeLabels) continue;
    p.setPen(Qt::black);
    p.drawText(QRectF(X(s) - 40, plot.bottom() + 4, 80, 16), Qt::AlignCenter, QString::number(s, 'g', 3));
    p.setPen(QPen(QColor(220, 220, 220), 1));
  }
  p.setPen(QPen(QColor(120, 120, 120), 1, Qt::DashLine));
  for (size_t l = 1; l < r.levelStartSeconds.size(); ++l) {
    const double x = X(r.levelStartSeconds[l]);
    p.drawLine(QPointF(x, plot.top()), QPointF(x, plot.bottom()));
    p.drawText(QPointF(x + 4, plot.top() + 14), QString("level %1").arg(l));
  }
  p.setPen(QPen(Qt::black, 1));
  p.drawRect(plot);
  if (panel.before) p.drawLine(QPointF(X(0), plot.top()), QPointF(X(0), plot.bottom()));
  p.save();
  p.translate(18, plot.center().y());
  p.rotate(-90);
  p.drawText(QRectF(-150, -10, 300, 20), Qt::AlignCenter, panel.label);
  p.restore();
  p.save();
  p.setClipRect(plot.adjusted(-2, -2, 2, 2));
  for (size_t s = 0; s < scene.structures.size(); ++s) {
    const QColor c = structureColour(s, scene.structures.size());
    QPainterPath line;
    bool started = false;
    for (const TimelineSample& t : r.timeline) {
      if (t.structure != int(s) || std::isnan(panel.value(t))) continue;
      const QPointF q(X(t.seconds), Y(panel.value(t)));
      if (!started) line.moveTo(q);
      else line.lineTo(q);
      started = true;
    }
    p.setPen(QPen(c, 2));
    p.drawPath(line);
    if (panel.before && !std::isnan(panel.before(s)) && !std::isnan(panel.after(s))) {
      p.setPen(QPen(c, 1.5, Qt::DashLine));
      p.drawLine(QPointF(X(tMin), Y(panel.before(s))), QPointF(X(0), Y(panel.after(s))));
    }
  }
  p.restore();
}
}  // namespace

void writeErrorPlot(const std::filesystem::path& path, const RunReport& r, const SceneDesc& scene) {
  const bool truth = r.hasGroundTruth();
  // With an initialisation, the plot starts where the model put the structures, the initialisation's
  // time before simulation time 0: one straight step per structure from the model to the start.
  const bool initialised = truth && r.stages.size() >= 2 && r.stages[1].name == "initialisation";
  const double tMin = initialised ? -std::max(r.initialisation.seconds, 1e-3) : 0.0;
  double tMax = 1e-9;
  for (const TimelineSample& t : r.timeline) tMax = std::max(tMax, t.seconds);
  auto stageValue = [&](std::size_t stage) {
    return [&r, stage](std::size_t s) { return s < r.stages[stage].assdMm.size() ? r.stages[stage].assdMm[s] : std::nan(""); };
  };
  auto structureValue = [&r](double StructureResult::*field) {
    return [&r, field](std::size_t s) { return s < r.structures.size() ? r.structures[s].*field : std::nan(""); };
  };
  // Without a ground truth, the mean displacement alone; with one, ASSD above and Dice below.
  Panel error{{}, 0.0, 1e-9, truth ? "ASSD (mm)" : "mean displacement per step (mm)",
              [truth](const TimelineSample& t) { return truth ? t.assdMm : t.meanDisplacementMm; }, {}, {}};
  Panel dice{{}, 1.0, 1.0, "Dice", [](const TimelineSample& t) { return t.dice; }, {}, {}};
  if (initialised) {
    error.before = stageValue(0), error.after = stageValue(1);
    dice.before = structureValue(&StructureResult::diceModel), dice.after = structureValue(&StructureResult::diceInitial);
  }
  bool withDice = false;
  for (const TimelineSample& t : r.timeline) {
    if (!std::isnan(error.value(t))) error.yMax = std::max(error.yMax, error.value(t));
    if (!std::isnan(t.dice)) dice.yMin = std::min(dice.yMin, t.dice), withDice = true;
  }
  for (std::size_t s = 0; initialised && s < scene.structures.size(); ++s) {
    if (!std::isnan(error.before(s))) error.yMax = std::max(error.yMax, error.before(s));
    if (!std::isnan(dice.before(s))) dice.yMin = std::min(dice.yMin, dice.before(s));
  }
  error.yMax *= 1.05;
  dice.yMin = std::max(0.0, std::floor(dice.yMin * 10.0 - 0.5) / 10.0);  // a tenth below the lowest
  const int W = 1100, H = withDice ? 850 : 650, left = 80, right = 230, top = 40, bottom = 60, gap = 40;
  const double errorHeight = withDice ? 430 : H - top - bottom;
  error.rect = QRectF(left, top, W - left - right, errorHeight);
  dice.rect = QRectF(left, top + errorHeight + gap, W - left - right, H - top - bottom - errorHeight - gap);
  QImage image(W, H, QImage::Format_RGB32);
  image.fill(Qt::white);
  QPainter p(&image);
  p.setRenderHint(QPainter::Antialiasing);
  QFont font = p.font();
  font.setPixelSize(13);
  p.setFont(font);
  drawPanel(p, error, r, scene, tMin, tMax, !withDice);
  if (withDice) drawPanel(p, dice, r, scene, tMin, tMax, true);
  const QRectF& lowest = withDice ? dice.rect : error.rect;
  p.setPen(Qt::black);
  if (initialised)
    p.drawText(QRectF(left + 4, top + 2, lowest.width() * 0.5, 16), Qt::AlignLeft,
               QString("initialisation (%1 s)").arg(r.initialisation.seconds, 0, 'f', 2));
  p.drawText(QRectF(left, H - 28, lowest.width(), 20), Qt::AlignCenter,
             initialised ? "run time (s): the initialisation, then simulation time" : "simulation time (s)");
  p.drawText(QRectF(left, 8, lowest.width(), 24), Qt::AlignCenter,
             QString("Error against run time (%1, %2)").arg(QString::fromStdString(r.backend)).arg(QString::fromStdString(r.device)));
  for (size_t s = 0; s < scene.structures.size(); ++s) {
    const double y = top + 10 + 20.0 * s;
    p.setPen(QPen(structureColour(s, scene.structures.size()), 2));
    p.drawLine(QPointF(W - right + 15, y), QPointF(W - right + 40, y));
    p.setPen(Qt::black);
    p.drawText(QPointF(W - right + 46, y + 5), QString::fromStdString(scene.structures[s].name));
  }
  p.end();
  savePng(image, path);
}

}  // namespace sinew

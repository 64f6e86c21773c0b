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

namespace sinew {

void writeErrorPlot(const std::filesystem::path& path, const RunReport& r, const SceneDesc& scene) {
  const bool assd = r.hasGroundTruth();
  auto value = [&](const TimelineSample& t) { return assd ? t.assdMm : t.meanDisplacementMm; };
  double tMax = 1e-9, yMax = 1e-9;
  for (const TimelineSample& t : r.timeline) {
    tMax = std::max(tMax, t.seconds);
    if (!std::isnan(value(t))) yMax = std::max(yMax, value(t));
  }
  // With an initialisation, the plot starts where the model put the structures, the initialisation's
  // time before simulation time 0: one straight step per structure from the model to the start.
  const bool initialised = assd && r.stages.size() >= 2 && r.stages[1].name == "initialisation";
  const double tMin = initialised ? -std::max(r.initialisation.seconds, 1e-3) : 0.0;
  if (initialised)
    for (double v : r.stages[0].assdMm)
      if (!std::isnan(v)) yMax = std::max(yMax, v);
  yMax *= 1.05;
  const int W = 1100, H = 650, left = 80, right = 230, top = 40, bottom = 60;
  QImage image(W, H, QImage::Format_RGB32);
  image.fill(Qt::white);
  QPainter p(&image);
  p.setRenderHint(QPainter::Antialiasing);
  QFont font = p.font();
  font.setPixelSize(13);
  p.setFont(font);
  const QRectF plot(left, top, W - left - right, H - top - bottom);
  auto X = [&](double s) { return plot.left() + plot.width() * (s - tMin) / (tMax - tMin); };
  auto Y = [&](double v) { return plot.bottom() - plot.height() * v / yMax; };

  p.setPen(QPen(QColor(220, 220, 220), 1));
  for (int i = 0; i <= 5; ++i) {
    const double v = yMax * i / 5, s = tMin + (tMax - tMin) * i / 5;
    p.drawLine(QPointF(plot.left(), Y(v)), QPointF(plot.right(), Y(v)));
    p.drawLine(QPointF(X(s), plot.top()), QPointF(X(s), plot.bottom()));
    p.setPen(Qt::black);
    p.drawText(QRectF(0, Y(v) - 8, left - 8, 16), Qt::AlignRight | Qt::AlignVCenter, QString::number(v, 'f', 2));
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
  if (initialised) {
    p.drawLine(QPointF(X(0), plot.top()), QPointF(X(0), plot.bottom()));
    p.drawText(QRectF(X(tMin) + 4, plot.top() + 2, X(0) - X(tMin) - 8, 16), Qt::AlignLeft,
               QString("initialisation (%1 s)").arg(r.initialisation.seconds, 0, 'f', 2));
  }
  p.drawText(QRectF(plot.left(), H - 28, plot.width(), 20), Qt::AlignCenter,
             initialised ? "run time (s): the initialisation, then simulation time" : "simulation time (s)");
  p.save();
  p.translate(18, plot.center().y());
  p.rotate(-90);
  p.drawText(QRectF(-150, -10, 300, 20), Qt::AlignCenter, assd ? "ASSD (mm)" : "mean displacement per step (mm)");
  p.restore();
  p.drawText(QRectF(plot.left(), 8, plot.width(), 24), Qt::AlignCenter,
             QString("Error against run time (%1, %2)").arg(QString::fromStdString(r.backend)).arg(QString::fromStdString(r.device)));

  for (size_t s = 0; s < scene.structures.size(); ++s) {
    const QColor c = structureColour(s, scene.structures.size());
    QPainterPath line;
    bool started = false;
    for (const TimelineSample& t : r.timeline) {
      if (t.structure != int(s) || std::isnan(value(t))) continue;
      const QPointF q(X(t.seconds), Y(value(t)));
      if (!started) line.moveTo(q);
      else line.lineTo(q);
      started = true;
    }
    p.setPen(QPen(c, 2));
    p.drawPath(line);
    if (initialised && s < r.stages[0].assdMm.size() && !std::isnan(r.stages[0].assdMm[s])) {
      p.setPen(QPen(c, 1.5, Qt::DashLine));
      p.drawLine(QPointF(X(tMin), Y(r.stages[0].assdMm[s])), QPointF(X(0), Y(r.stages[1].assdMm[s])));
      p.setPen(QPen(c, 2));
    }
    const double y = top + 10 + 20.0 * s;
    p.drawLine(QPointF(W - right + 15, y), QPointF(W - right + 40, y));
    p.setPen(Qt::black);
    p.drawText(QPointF(W - right + 46, y + 5), QString::fromStdString(scene.structures[s].name));
  }
  p.end();
  savePng(image, path);
}

}  // namespace sinew

// The cohort report's plots, drawn with QPainter on a QImage (a QGuiApplication on the offscreen
// platform must exist: sinew-cohort creates one).
#include "cohort_report.h"

#include "pictures.h"

#include <QFont>
#include <QImage>
#include <QPainter>

#include <algorithm>
#include <cmath>

namespace sinew::cohort {

namespace {

struct Canvas {
  QImage image;
  QPainter painter;
  QRectF plot;
  double yMin = 0, yMax = 1;

  Canvas(int width, int height, int bottom) : image(width, height, QImage::Format_RGB32) {
    image.fill(Qt::white);
    painter.begin(&image);
    painter.setRenderHint(QPainter::Antialiasing);
    QFont f = painter.font();
    f.setPixelSize(13);
    painter.setFont(f);
    plot = QRectF(80, 40, width - 110, height - 40 - bottom);
  }
  double Y(double v) const { return plot.bottom() - plot.height() * (v - yMin) / (yMax - yMin); }

  // Grid, y labels, frame and titles.
  void axes(const QString& title, const QString& yLabel) {
    const int ticks = 5;
    for (int i = 0; i <= ticks; ++i) {
      const double v = yMin + (yMax - yMin) * i / ticks;
      painter.setPen(QPen(QColor(225, 225, 225), 1));
      painter.drawLine(QPointF(plot.left(), Y(v)), QPointF(plot.right(), Y(v)));
      painter.setPen(Qt::black);
      painter.drawText(QRectF(0, Y(v) - 8, plot.left() - 8, 16), Qt::AlignRight | Qt::AlignVCenter,
                       QString::number(v, 'g', 3));
    }
    painter.setPen(QPen(Qt::black, 1));
    painter.drawRect(plot);
    painter.drawText(QRectF(plot.left(), 8, plot.width(), 24), Qt::AlignCenter, title);
    painter.save();
    painter.translate(18, plot.center().y());
    painter.rotate(-90);
    painter.drawText(QRectF(-150, -10, 300, 20), Qt::AlignCenter, yLabel);
    painter.restore();
  }
  // A category name under x, turned 45 degrees so long names fit.
  void category(double x, const QString& name) {
    painter.save();
    painter.setPen(Qt::black);
    painter.translate(x, plot.bottom() + 8);
    painter.rotate(45);
    painter.drawText(QPointF(0, 4), name);
    painter.restore();
  }
  void save(const std::filesystem::path& path) {
    painter.end();
    savePng(image, path);
  }
};

void range(Canvas& c, double lo, double hi) {
  if (!(hi > lo)) hi = lo + 1.0;
  const double pad = 0.05 * (hi - lo);
  c.yMin = std::max(0.0, lo - pad);
  c.yMax = hi + pad;
}

}  // namespace

void writeBoxPlot(const std::filesystem::path& path, const CohortReport& report, double StructureResult::*field,
                  const std::string& title, const std::string& axis) {
  const size_t n = report.structures.size();
  Canvas c(int(std::max<size_t>(500, 110 + 70 * n)), 600, 140);
  double lo = INFINITY, hi = -INFINITY;
  for (const StructureResult& r : report.results)
    if (!std::isnan(r.*field)) lo = std::min(lo, r.*field), hi = std::max(hi, r.*field);
  if (std::isinf(lo)) lo = 0, hi = 1;
  range(c, lo, hi);
  const int subjects = int(report.subjects.size());
  c.axes(QString::fromStdString(title) + QString(" (%1 of %2 subjects with results)").arg(report.completed + report.degraded).arg(subjects),
         QString::fromStdString(axis));
  const double step = c.plot.width() / double(std::max<size_t>(n, 1));
  for (size_t k = 0; k < n; ++k) {
    const double x = c.plot.left() + step * (double(k) + 0.5), w = std::min(40.0, step * 0.5);
    const QColor colour = structureColour(k, n);
    std::vector<double> v = report.metric(report.structures[k], field);
    v.erase(std::remove_if(v.begin(), v.end(), [](double a) { return std::isnan(a); }), v.end());
    c.category(x - 4, QString::fromStdString(report.structures[k]));
    if (v.empty()) continue;
    const Statistics s = statistics(v);
    // Tukey's whiskers: the furthest values within 1.5 IQR of the box; beyond them, points.
    const double iqr = s.q3 - s.q1, lowFence = s.q1 - 1.5 * iqr, highFence = s.q3 + 1.5 * iqr;
    double whiskerLo = s.q1, whiskerHi = s.q3;
    for (double a : v) {
      if (a >= lowFence) whiskerLo = std::min(whiskerLo, a);
      if (a <= highFence) whiskerHi = std::max(whiskerHi, a);
    }
    c.painter.setPen(QPen(Qt::black, 1));
    c.painter.drawLine(QPointF(x, c.Y(whiskerLo)), QPointF(x, c.Y(s.q1)));
    c.painter.drawLine(QPointF(x, c.Y(s.q3)), QPointF(x, c.Y(whiskerHi)));
    c.painter.drawLine(QPointF(x - w / 4, c.Y(whiskerLo)), QPointF(x + w / 4, c.Y(whiskerLo)));
    c.painter.drawLine(QPointF(x - w / 4, c.Y(whiskerHi)), QPointF(x + w / 4, c.Y(whiskerHi)));
    QColor fill = colour;
    fill.setAlpha(110);
    c.painter.setBrush(fill);
    c.painter.drawRect(QRectF(QPointF(x - w / 2, c.Y(s.q3)), QPointF(x + w / 2, c.Y(s.q1))));
    c.painter.setPen(QPen(Qt::black, 2));
    c.painter.drawLine(QPointF(x - w / 2, c.Y(s.median)), QPointF(x + w / 2, c.Y(s.median)));
    c.painter.setPen(QPen(colour.darker(140), 1));
    c.painter.setBrush(Qt::NoBrush);
    for (double a : v)
      if (a < lowFence || a > highFence) c.painter.drawEllipse(QPointF(x, c.Y(a)), 3, 3);
  }
  c.save(path);
}

void writeRunTimePlot(const std::filesystem::path& path, const CohortReport& report) {
  const size_t n = report.subjects.size();
  Canvas c(int(std::max<size_t>(700, 110 + 26 * n)), 560, 120);
  double hi = 0;
  for (const SubjectRow& r : report.subjects) hi = std::max(hi, r.status.seconds);
  range(c, 0, hi);
  c.yMin = 0;
  c.axes(QString("Run time per subject (%1 failed in red or grey, %2 degraded in orange)").arg(report.failed).arg(report.degraded),
         "wall time, every attempt (s)");
  const double step = c.plot.width() / double(std::max<size_t>(n, 1));
  for (size_t k = 0; k < n; ++k) {
    const SubjectRow& r = report.subjects[k];
    const double x = c.plot.left() + step * (double(k) + 0.5), w = step * 0.7;
    c.category(x - 4, QString::fromStdString(r.id));
    if (!r.status.attempts || r.status.status == "pending") continue;
    const QColor colour = r.status.status == "completed"     ? QColor(70, 160, 90)
                          : r.status.status == "degraded"    ? QColor(230, 150, 40)
                          : r.status.status == "interrupted" ? QColor(150, 150, 150)
                                                             : QColor(200, 50, 50);
    c.painter.setPen(Qt::NoPen);
    c.painter.setBrush(colour);
    c.painter.drawRect(QRectF(QPointF(x - w / 2, c.Y(r.status.seconds)), QPointF(x + w / 2, c.Y(0))));
  }
  c.save(path);
}

}  // namespace sinew::cohort

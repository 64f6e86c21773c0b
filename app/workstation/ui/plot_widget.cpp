#include "plot_widget.h"

#include <QPainter>
#include <QPainterPath>

#include <algorithm>
#include <cmath>

namespace sinew {

PlotWidget::PlotWidget(QWidget* parent) : QWidget(parent) {
  setMinimumHeight(120);
  setAccessibleName("Error against time");
}

void PlotWidget::setSamples(const std::vector<SessionSample>& samples, bool error) {
  samples_ = samples;
  error_ = error;
  update();
}

void PlotWidget::paintEvent(QPaintEvent*) {
  QPainter p(this);
  p.setRenderHint(QPainter::Antialiasing);
  p.fillRect(rect(), palette().base());
  // With the error, the mean Dice beside it on a right-hand axis from 0 to 1.
  const bool dice =
      error_ && std::any_of(samples_.begin(), samples_.end(), [](const SessionSample& s) { return std::isfinite(s.dice); });
  const QRectF area = QRectF(rect()).adjusted(48, dice ? 20 : 10, dice ? -34 : -10, -28);
  p.setPen(palette().text().color());
  const QString yLabel = error_ ? tr("mean ASSD (mm)") : tr("mean displacement (mm/step)");
  p.drawText(QRectF(4, 0, width() - 8, 14), Qt::AlignLeft, yLabel);
  if (dice) {
    p.setPen(QColor(40, 110, 200));
    p.drawText(QRectF(4, 0, width() - 8, 14), Qt::AlignRight, tr("mean Dice"));
    p.drawText(QRectF(area.right() + 4, area.top() - 6, 30, 14), Qt::AlignLeft, "1");
    p.drawText(QRectF(area.right() + 4, area.bottom() - 8, 30, 14), Qt::AlignLeft, "0");
    p.setPen(palette().text().color());
  }
  p.drawText(QRectF(area.left(), area.bottom() + 12, area.width(), 14), Qt::AlignRight, tr("simulation time (s)"));
  p.drawRect(area);
  auto value = [&](const SessionSample& s) { return error_ ? s.assdMm : s.displacementMm; };
  std::vector<const SessionSample*> pts;
  for (const auto& s : samples_)
    if (std::isfinite(value(s))) pts.push_back(&s);
  if (pts.size() < 2) {
    p.drawText(area, Qt::AlignCenter, tr("Run to see %1").arg(error_ ? tr("the error") : tr("the displacement")));
    return;
  }
  double t1 = 1e-9, vmax = 1e-12;
  for (auto* s : pts) t1 = std::max(t1, s->seconds), vmax = std::max(vmax, value(*s));
  vmax *= 1.1;
  auto map = [&](double t, double v) {
    return QPointF(area.left() + area.width() * t / t1, area.bottom() - area.height() * v / vmax);
  };
  p.drawText(QRectF(0, area.top() - 6, 44, 14), Qt::AlignRight, QString::number(vmax, 'g', 3));
  p.drawText(QRectF(0, area.bottom() - 8, 44, 14), Qt::AlignRight, "0");
  p.drawText(QRectF(area.left(), area.bottom() + 2, 80, 14), Qt::AlignLeft, "0");
  p.drawText(QRectF(area.right() - 80, area.bottom() + 2, 80, 14), Qt::AlignRight, QString::number(t1, 'g', 3));
  // Level changes as dashed verticals.
  p.setPen(QPen(palette().mid().color(), 1, Qt::DashLine));
  for (size_t i = 1; i < pts.size(); ++i)
    if (pts[i]->level != pts[i - 1]->level) {
      const double x = map(pts[i]->seconds, 0).x();
      p.drawLine(QPointF(x, area.top()), QPointF(x, area.bottom()));
    }
  QPainterPath path(map(pts[0]->seconds, value(*pts[0])));
  for (size_t i = 1; i < pts.size(); ++i) path.lineTo(map(pts[i]->seconds, value(*pts[i])));
  p.setPen(QPen(QColor(230, 120, 40), 2));
  p.drawPath(path);
  if (!dice) return;
  QPainterPath dicePath;
  bool started = false;
  for (const SessionSample* s : pts) {
    if (!std::isfinite(s->dice)) continue;
    const QPointF q(map(s->seconds, 0).x(), area.bottom() - area.height() * s->dice);
    started ? dicePath.lineTo(q) : dicePath.moveTo(q);
    started = true;
  }
  p.setPen(QPen(QColor(40, 110, 200), 2));
  p.drawPath(dicePath);
}

}  // namespace sinew

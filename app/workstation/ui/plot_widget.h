// The live plot: mean ASSD and mean Dice against simulation time when ground truth is loaded,
// otherwise the mean displacement per step (how much the meshes still move), with level changes
// marked.
#pragma once

#include "segmentation_session.h"

#include <QWidget>

namespace sinew {

class PlotWidget : public QWidget {
  Q_OBJECT
public:
  explicit PlotWidget(QWidget* parent = nullptr);
  void setSamples(const std::vector<SessionSample>& samples, bool error);
  QSize sizeHint() const override { return {320, 180}; }

protected:
  void paintEvent(QPaintEvent*) override;

private:
  std::vector<SessionSample> samples_;
  bool error_ = false;
};

}  // namespace sinew

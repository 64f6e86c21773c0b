// The side panels, bound to the session and display models (they hold no state of their own):
// the scene panel (structures: visibility, colour, level), the parameters panel generated from the
// parameter declarations, and the schedule panel.
#pragma once

#include "display_scene.h"
#include "segmentation_session.h"

#include <QWidget>

#include <functional>
#include <vector>

class QCheckBox;
class QDoubleSpinBox;
class QLabel;
class QSlider;
class QTableWidget;
class QVBoxLayout;

namespace sinew {

class ScenePanel : public QWidget {
  Q_OBJECT
public:
  ScenePanel(SegmentationSession& session, DisplayScene& display, QWidget* parent = nullptr);
  void rebuild();  // new scene
  void refresh();  // level, vertex counts; image fits that the state has moved on from are cleared
  // Scores every structure's image fit where it now lies (SegmentationSession::scoreImageFit) into
  // the table's column, shown until the state changes; returns the structures below kPoorImageFit
  // ("Name 0.21, ..."), empty when none.
  QString showImageFit();

Q_SIGNALS:
  void selectionChanged();
  void lookChanged();

private:
  SegmentationSession& session_;
  DisplayScene& display_;
  QTableWidget* table_;
};

// One row per declared parameter: a slider and a spin box over [min, max], help as tooltip.
// Per-structure parameters act on the selected structure, or on all with "All structures".
class ParametersPanel : public QWidget {
  Q_OBJECT
public:
  ParametersPanel(SegmentationSession& session, DisplayScene& display, QWidget* parent = nullptr);
  void rebuild();
  void refresh();  // values from the session (after undo, selection change)

Q_SIGNALS:
  void edited();
  void failed(const QString& message);

private:
  struct Row {
    std::string owner, param;
    bool perStructure = true;
    double min = 0, max = 1;
    QSlider* slider = nullptr;
    QDoubleSpinBox* spin = nullptr;
  };
  void apply(Row& row, double value, bool continuing);

  SegmentationSession& session_;
  DisplayScene& display_;
  QVBoxLayout* groups_;
  QCheckBox* all_;
  QLabel* target_;
  std::vector<Row> rows_;
};

class SchedulePanel : public QWidget {
  Q_OBJECT
public:
  SchedulePanel(SegmentationSession& session, QWidget* parent = nullptr);
  void rebuild();
  void refresh();
  double budgetMs() const;
  void setBudgetMs(double ms);

Q_SIGNALS:
  void budgetChanged(double ms);

private:
  SegmentationSession& session_;
  QTableWidget* table_;
  QDoubleSpinBox* budget_;
  QLabel* info_;
};

}  // namespace sinew

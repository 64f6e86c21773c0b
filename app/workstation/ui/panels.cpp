#include "panels.h"

#include <QBrush>
#include <QCheckBox>
#include <QColorDialog>
#include <QDoubleSpinBox>
#include <QFormLayout>
#include <QGroupBox>
#include <QHBoxLayout>
#include <QHeaderView>
#include <QLabel>
#include <QScrollArea>
#include <QSlider>
#include <QTableWidget>
#include <QVBoxLayout>

#include <cmath>

namespace sinew {

namespace {
QColor toQColor(const std::array<double, 3>& c) { return QColor::fromRgbF(float(c[0]), float(c[1]), float(c[2])); }
}  // namespace

// --- scene ---------------------------------------------------------------------------------------

ScenePanel::ScenePanel(SegmentationSession& session, DisplayScene& display, QWidget* parent)
    : QWidget(parent), session_(session), display_(display), table_(new QTableWidget(this)) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(2, 2, 2, 2);
  layout->addWidget(table_);
  table_->setColumnCount(5);
  table_->setHorizontalHeaderLabels({tr("Show"), tr("Colour"), tr("Structure"), tr("Vertices"), tr("Image fit")});
  table_->horizontalHeaderItem(4)->setToolTip(
      tr("How well the image agrees with the trained profiles where the structure lies (1: as trained; "
         "below %1: check it). Scored at the end of the schedule, cleared when the meshes change.")
          .arg(kPoorImageFit));
  table_->horizontalHeader()->setSectionResizeMode(2, QHeaderView::Stretch);
  table_->verticalHeader()->hide();
  table_->setSelectionBehavior(QAbstractItemView::SelectRows);
  table_->setSelectionMode(QAbstractItemView::SingleSelection);
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setAccessibleName("Structures");
  connect(table_, &QTableWidget::currentCellChanged, this, [this](int row) {
    if (row < 0 || row >= display_.structureCount()) return;
    display_.selected = row;
    Q_EMIT selectionChanged();
  });
  connect(table_, &QTableWidget::itemChanged, this, [this](QTableWidgetItem* item) {
    if (item->column() != 0 || item->row() >= display_.structureCount()) return;
    display_.look(item->row()).visible = item->checkState() == Qt::Checked;
    Q_EMIT lookChanged();
  });
  connect(table_, &QTableWidget::cellDoubleClicked, this, [this](int row, int column) {
    if (column != 1) return;
    const QColor c = QColorDialog::getColor(toQColor(display_.look(row).colour), this, tr("Structure colour"));
    if (!c.isValid()) return;
    display_.look(row).colour = {c.redF(), c.greenF(), c.blueF()};
    table_->item(row, 1)->setBackground(c);
    Q_EMIT lookChanged();
  });
}

void ScenePanel::rebuild() {
  const QSignalBlocker block(table_);
  table_->setRowCount(0);
  if (!session_.isOpen()) return;
  table_->setRowCount(display_.structureCount());
  for (Index s = 0; s < display_.structureCount(); ++s) {
    auto* show = new QTableWidgetItem;
    show->setFlags(Qt::ItemIsUserCheckable | Qt::ItemIsEnabled | Qt::ItemIsSelectable);
    show->setCheckState(display_.look(s).visible ? Qt::Checked : Qt::Unchecked);
    table_->setItem(s, 0, show);
    auto* colour = new QTableWidgetItem;
    colour->setBackground(toQColor(display_.look(s).colour));
    colour->setToolTip(tr("Double-click to change"));
    table_->setItem(s, 1, colour);
    table_->setItem(s, 2, new QTableWidgetItem(QString::fromStdString(display_.look(s).name)));
    table_->setItem(s, 3, new QTableWidgetItem);
    table_->setItem(s, 4, new QTableWidgetItem);
  }
  table_->selectRow(int(display_.selected));
  refresh();
}

void ScenePanel::refresh() {
  if (!session_.isOpen()) return;
  const QSignalBlocker block(table_);
  MeshStore& store = session_.simulation().store();
  const std::vector<StructureImageFit> fits = session_.imageFit();
  for (Index s = 0; s < display_.structureCount() && s < table_->rowCount(); ++s) {
    table_->item(s, 3)->setText(QString::number(store.range(s).vertexCount()));
    const double fit = size_t(s) < fits.size() ? fits[s].fit : std::nan("");
    QTableWidgetItem* cell = table_->item(s, 4);
    cell->setText(std::isnan(fit) ? QString() : QString::number(fit, 'f', 2));
    cell->setForeground(fit < kPoorImageFit ? QBrush(Qt::red) : QBrush());
  }
}

QString ScenePanel::showImageFit() {
  if (!session_.isOpen()) return {};
  const std::vector<StructureImageFit> fits = session_.scoreImageFit();
  refresh();
  QString poor;
  for (size_t s = 0; s < fits.size() && s < size_t(display_.structureCount()); ++s)
    if (fits[s].fit < kPoorImageFit)
      poor += (poor.isEmpty() ? "" : ", ") + QString::fromStdString(display_.look(Index(s)).name) + " " +
              QString::number(fits[s].fit, 'f', 2);
  return poor;
}

// --- parameters ----------------------------------------------------------------------------------

ParametersPanel::ParametersPanel(SegmentationSession& session, DisplayScene& display, QWidget* parent)
    : QWidget(parent), session_(session), display_(display) {
  auto* outer = new QVBoxLayout(this);
  outer->setContentsMargins(2, 2, 2, 2);
  all_ = new QCheckBox(tr("All structures"), this);
  all_->setToolTip(tr("Per-structure parameters act on every structure instead of the selected one"));
  target_ = new QLabel(this);
  auto* top = new QHBoxLayout;
  top->addWidget(target_, 1);
  top->addWidget(all_);
  outer->addLayout(top);
  auto* scroll = new QScrollArea(this);
  scroll->setWidgetResizable(true);
  auto* inner = new QWidget;
  groups_ = new QVBoxLayout(inner);
  groups_->addStretch();
  scroll->setWidget(inner);
  outer->addWidget(scroll);
  connect(all_, &QCheckBox::toggled, this, [this] { refresh(); });
}

void ParametersPanel::rebuild() {
  while (groups_->count() > 1) {
    QLayoutItem* item = groups_->takeAt(0);
    delete item->widget();
    delete item;
  }
  rows_.clear();
  if (!session_.isOpen()) return;
  Simulation& sim = session_.simulation();
  std::vector<std::pair<std::string, std::span<const ParamDecl>>> owners;
  for (const std::string& f : sim.forceNames()) owners.emplace_back(f, sim.forceParams(f).decls());
  owners.emplace_back(sim.integratorName(), sim.integratorParams().decls());
  for (const auto& [owner, decls] : owners) {
    const bool isIntegrator = owner == sim.integratorName();
    auto* box = new QGroupBox(QString::fromStdString(isIntegrator ? "integrator: " + owner : owner));
    auto* form = new QFormLayout(box);
    for (const ParamDecl& d : decls) {
      Row row{owner, d.name, d.perStructure, d.min, d.max};
      auto* line = new QWidget;
      auto* h = new QHBoxLayout(line);
      h->setContentsMargins(0, 0, 0, 0);
      row.slider = new QSlider(Qt::Horizontal);
      row.slider->setRange(0, 1000);
      row.spin = new QDoubleSpinBox;
      row.spin->setRange(d.min, d.max);
      row.spin->setDecimals(d.max - d.min >= 100 ? 1 : 3);
      row.spin->setSingleStep((d.max - d.min) / 100.0);
      row.spin->setSuffix(d.unit.empty() ? "" : QString(" ") + QString::fromStdString(d.unit));
      const QString help = QString::fromStdString(d.help + (d.perStructure ? "" : " (shared by all structures)"));
      row.slider->setToolTip(help);
      row.spin->setToolTip(help);
      row.slider->setAccessibleName(QString::fromStdString(owner + "." + d.name));
      h->addWidget(row.slider, 1);
      h->addWidget(row.spin);
      form->addRow(QString::fromStdString(d.name), line);
      rows_.push_back(row);
      const size_t index = rows_.size() - 1;
      connect(row.slider, &QSlider::valueChanged, this, [this, index](int v) {
        Row& r = rows_[index];
        apply(r, r.min + (r.max - r.min) * v / 1000.0, r.slider->isSliderDown());
      });
      // Pressing the slider starts a new undo step; moving it while held extends that step.
      connect(row.slider, &QSlider::sliderPressed, this, [this] { session_.endEdit(); });
      connect(row.spin, &QDoubleSpinBox::valueChanged, this, [this, index](double v) { apply(rows_[index], v, false); });
    }
    groups_->insertWidget(groups_->count() - 1, box);
  }
  refresh();
}

void ParametersPanel::apply(Row& row, double value, bool continuing) {
  const Index structure = all_->isChecked() || !row.perStructure ? -1 : display_.selected;
  try {
    session_.setParameter(row.owner, structure, row.param, std::clamp(value, row.min, row.max), continuing);
  } catch (const std::exception& e) {
    Q_EMIT failed(QString::fromUtf8(e.what()));
  }
  refresh();
  Q_EMIT edited();
}

void ParametersPanel::refresh() {
  if (!session_.isOpen()) return;
  const Index s = display_.selected;
  target_->setText(all_->isChecked() ? tr("Editing: all structures")
                                     : tr("Editing: %1").arg(QString::fromStdString(display_.look(s).name)));
  for (Row& r : rows_) {
    const double v = session_.parameter(r.owner, s, r.param);
    const QSignalBlocker b1(r.slider), b2(r.spin);
    r.spin->setValue(v);
    if (!r.slider->isSliderDown())
      r.slider->setValue(static_cast<int>(std::lround(1000.0 * (v - r.min) / std::max(r.max - r.min, 1e-12))));
  }
}

// --- schedule ------------------------------------------------------------------------------------

SchedulePanel::SchedulePanel(SegmentationSession& session, QWidget* parent)
    : QWidget(parent), session_(session), table_(new QTableWidget(this)) {
  auto* layout = new QVBoxLayout(this);
  layout->setContentsMargins(2, 2, 2, 2);
  info_ = new QLabel(this);
  layout->addWidget(info_);
  table_->setColumnCount(2);
  table_->setHorizontalHeaderLabels({tr("Iterations"), tr("Done")});
  table_->horizontalHeader()->setSectionResizeMode(QHeaderView::Stretch);
  table_->setEditTriggers(QAbstractItemView::NoEditTriggers);
  table_->setSelectionMode(QAbstractItemView::NoSelection);
  layout->addWidget(table_);
  auto* form = new QFormLayout;
  budget_ = new QDoubleSpinBox(this);
  budget_->setRange(1, 1000);
  budget_->setValue(30);
  budget_->setSuffix(" ms");
  budget_->setToolTip(tr("Simulation time per displayed frame while running (paper 000 section 4.4): lower keeps "
                         "the views more responsive, higher simulates faster"));
  form->addRow(tr("Frame budget"), budget_);
  layout->addLayout(form);
  connect(budget_, &QDoubleSpinBox::valueChanged, this, &SchedulePanel::budgetChanged);
}

double SchedulePanel::budgetMs() const { return budget_->value(); }
void SchedulePanel::setBudgetMs(double ms) { budget_->setValue(ms); }

void SchedulePanel::rebuild() {
  table_->setRowCount(0);
  if (!session_.isOpen()) return;
  const auto& schedule = session_.scene().schedule;
  table_->setRowCount(int(schedule.size()));
  QStringList levels;
  for (size_t l = 0; l < schedule.size(); ++l) {
    levels << tr("Level %1").arg(l);
    table_->setItem(int(l), 0, new QTableWidgetItem(QString::number(schedule[l].iterations)));
    table_->setItem(int(l), 1, new QTableWidgetItem);
  }
  table_->setVerticalHeaderLabels(levels);
  refresh();
}

void SchedulePanel::refresh() {
  if (!session_.isOpen() || table_->rowCount() == 0) return;
  const int level = session_.level();
  for (int l = 0; l < table_->rowCount(); ++l) {
    const QString done = l < level ? tr("done") : l == level ? QString::number(session_.levelIterationsDone()) : "";
    table_->item(l, 1)->setText(done);
    QFont f = table_->item(l, 0)->font();
    f.setBold(l == level);
    table_->item(l, 0)->setFont(f);
    table_->item(l, 1)->setFont(f);
  }
  info_->setText(tr("Integrator %1, level %2 of %3")
                     .arg(QString::fromStdString(session_.simulation().integratorName()))
                     .arg(level)
                     .arg(session_.levelCount()));
}

}  // namespace sinew

// The workstation on the real Colin27 data, under Xvfb (Mesa): it starts, renders every view,
// matches baseline images, adds an attraction point where the user clicked, pulls the mesh toward
// it, undoes exactly, and closes cleanly while running.
#include "builtin_plugins.h"
#include "display_scene.h"
#include "interaction_tool.h"
#include "main_window.h"
#include "ui_test_setup.h"
#include "slice_view.h"
#include "structure_colour.h"
#include "synthetic.h"
#include "sinew/core/collision_tree.h"
#include "sinew/core/image_fit.h"
#include "sinew/core/medial_axis.h"
#include "sinew/core/simplex_mesh.h"
#include "volume_view.h"

#include <QApplication>
#include <QDir>
#include <QFile>
#include <QImage>
#include <QProcess>
#include <QSurfaceFormat>
#include <QTableWidget>
#include <QTemporaryDir>
#include <QtTest>

#include <cmath>
#include <memory>
#include <set>

using namespace sinew;

namespace {
const QString kTemplates = "/usr/share/mricron/templates/";

// Distance from p to the nearest vertex of structure s (host store).
double nearestVertexDistance(SegmentationSession& session, Index s, const Vec3& p) {
  session.syncHost();
  MeshStore& store = session.simulation().store();
  const auto x = store.mesh(store.positions(), s);
  double best = 1e30;
  for (const Vec3& v : x) best = std::min(best, double((v - p).norm()));
  return best;
}

// A display point `mm` beyond structure s's vertex furthest along display +x, in its axial slice,
// which becomes the current one.
Vec3 beyondStructure(SegmentationSession& session, DisplayScene& display, Index s, float mm) {
  session.syncHost();
  MeshStore& store = session.simulation().store();
  Vec3 extreme = Vec3::Zero();
  float best = -1e30f;
  for (const Vec3& w : store.mesh(store.positions(), s)) {
    const Vec3 d = display.toDisplay(w);
    if (d.x() > best) best = d.x(), extreme = d;
  }
  display.cursor[2] = display.snapToSlice(2, extreme.z());
  Vec3 target = extreme + Vec3(mm, 0, 0);
  target.z() = float(display.cursor[2]);
  return target;
}

std::vector<Vec3> positions(SegmentationSession& session) {
  session.syncHost();
  const auto x = session.simulation().store().positions();
  return {x.begin(), x.end()};
}

// Fraction of pixels that differ from the view's background colour (top-left pixel).
double nonBackground(const QImage& img) {
  const QRgb bg = img.pixel(0, 0);
  long n = 0;
  for (int y = 0; y < img.height(); ++y)
    for (int x = 0; x < img.width(); ++x) n += img.pixel(x, y) != bg;
  return double(n) / (img.width() * img.height());
}

// How many pixels of two grabs of one view differ (both the same size).
long pixelsChanged(const QImage& a, const QImage& b) {
  long changed = 0;
  for (int y = 0; y < a.height(); ++y)
    for (int x = 0; x < a.width(); ++x) changed += a.pixel(x, y) != b.pixel(x, y);
  return changed;
}

}  // namespace

class TestWorkstation : public QObject {
  Q_OBJECT

private Q_SLOTS:
  void initTestCase() {
    if (!QFile::exists(kTemplates + "aal.nii.gz")) QSKIP("Debian package mricron-data is not installed");
    // A small scene: four structures, two levels.
    QCOMPARE(testing::makeColin27Scene(SINEW_MAKE_SCENE, dir_.filePath("scene.json"),
                                       "Hippocampus_L,Caudate_R,Putamen_L,Thalamus_R", "60,30"),
             0);
    registerBuiltinPlugins(registry_);
    registerBuiltinTools(tools_);
  }

  // The built-in tools are tool plugins: registered through the loader, and refused whole when
  // their names are taken (a tool plugin leaves nothing behind).
  void toolPluginsRegisterOnce() {
    ToolRegistry tools;
    registerBuiltinTools(tools);
    QCOMPARE(tools.tools().size(), std::size_t(5));
    QVERIFY(tools.find("navigate") && tools.find("attraction_points") && tools.find("landmarks") &&
            tools.find("include_points") && tools.find("exclude_points"));
    try {
      registerBuiltinTools(tools);
      QFAIL("a tool name was registered twice");
    } catch (const std::logic_error& e) {
      QVERIFY2(std::string(e.what()).find("tool 'navigate' is already registered") != std::string::npos, e.what());
    }
    QCOMPARE(tools.tools().size(), std::size_t(5));
  }

  void init() {
    WorkstationOptions o;
    o.backend = "cpu";
    o.persistSettings = false;
    window_ = std::make_unique<MainWindow>(registry_, tools_, o);
    window_->resize(1200, 800);
    window_->show();
    QVERIFY(QTest::qWaitForWindowExposed(window_.get()));
    QVERIFY(window_->openScene(dir_.filePath("scene.json")));
    QApplication::processEvents();
    QTest::qWait(100);
  }

  void cleanup() { window_.reset(); }

  void startsAndRendersEveryView() {
    QCOMPARE(window_->session().structureCount(), Index(4));
    QCOMPARE(window_->drawingPath(), std::string("host"));
    for (int a = 0; a < 3; ++a) {
      const QImage img = window_->sliceView(a)->grabFramebuffer();
      QVERIFY2(nonBackground(img) > 0.1, qPrintable(QString("slice view %1 is blank").arg(a)));
      // The contours are drawn in the structures' colours: some saturated pixels exist.
      long saturated = 0;
      for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x) saturated += QColor(img.pixel(x, y)).hsvSaturation() > 150;
      QVERIFY2(saturated > 50, qPrintable(QString("no contour in slice view %1").arg(a)));
    }
    const QImage vol = window_->volumeView()->grabFramebuffer();
    QVERIFY(nonBackground(vol) > 0.2);
  }

  void viewsMatchBaselines() {
    // Fixed view sizes so the pictures are comparable.
    window_->maximiseView(-1);
    const char* names[4] = {"sagittal", "coronal", "axial", "3d"};
    const bool update = qEnvironmentVariableIsSet("SINEW_UPDATE_BASELINES");
    for (int v = 0; v < 4; ++v) {
      VtkViewWidget* view = v < 3 ? static_cast<VtkViewWidget*>(window_->sliceView(v)) : window_->volumeView();
      view->setFixedSize(400, 320);
      QApplication::processEvents();
      if (v < 3) window_->sliceView(v)->resetCamera();
      else window_->volumeView()->resetCamera();
      const QImage img = view->grabFramebuffer().convertToFormat(QImage::Format_RGB32);
      const QString file = QString(SINEW_BASELINES) + "/" + names[v] + ".png";
      if (update) {
        QVERIFY(img.save(file));
        continue;
      }
      QImage base(file);
      QVERIFY2(!base.isNull(), qPrintable("missing baseline " + file + " (run with SINEW_UPDATE_BASELINES=1)"));
      base = base.convertToFormat(QImage::Format_RGB32);
      QCOMPARE(img.size(), base.size());
      // Threshold: at most 0.5 % of the pixels differ by more than 48 in any channel.
      long off = 0;
      for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x) {
          const QRgb a = img.pixel(x, y), b = base.pixel(x, y);
          off += std::abs(qRed(a) - qRed(b)) > 48 || std::abs(qGreen(a) - qGreen(b)) > 48 ||
                 std::abs(qBlue(a) - qBlue(b)) > 48;
        }
      const double fraction = double(off) / (img.width() * img.height());
      if (fraction > 0.005) img.save(QDir::temp().filePath(QString("sinew-%1-actual.png").arg(names[v])));
      QVERIFY2(fraction <= 0.005, qPrintable(QString("%1 view differs from its baseline in %2 % of pixels")
                                                .arg(names[v])
                                                .arg(100 * fraction, 0, 'f', 2)));
    }
  }

  // Click 4 mm outside the selected structure in the axial view: a point appears there (within a
  // voxel), the mesh moves toward it, and undo restores the state before the click exactly.
  void clickPlacesAttractionPointAndUndoRestores() {
    SegmentationSession& session = window_->session();
    DisplayScene& display = window_->display();
    session.step(20);
    window_->refreshViews();
    const Index s = 0;
    display.selected = s;
    const Vec3 target = beyondStructure(session, display, s, 4.0f);
    SliceView* axial = window_->sliceView(2);
    axial->invalidate();
    QApplication::processEvents();
    QTest::qWait(50);
    const std::vector<Vec3> before = positions(session);
    window_->selectTool("attraction_points");
    const QPointF at = axial->widgetPosition(target);
    QTest::mouseClick(axial, Qt::LeftButton, {}, at.toPoint());
    QCOMPARE(session.attractionPoints(s).size(), size_t(1));
    const Vec3 placed = session.attractionPoints(s)[0];
    const Vec3 expected = display.toWorld(target);
    const double voxel = display.geometry().spacing.maxCoeff();
    QVERIFY2((placed - expected).norm() <= voxel,
             qPrintable(QString("placed %1 mm from the click").arg((placed - expected).norm())));
    // Nothing moved yet: placing is an edit, not a step.
    QVERIFY(positions(session) == before);

    const double d0 = nearestVertexDistance(session, s, placed);
    session.step(40);
    const double d1 = nearestVertexDistance(session, s, placed);
    QVERIFY2(d1 < d0 - 1.0, qPrintable(QString("nearest vertex %1 -> %2 mm").arg(d0).arg(d1)));

    QVERIFY(session.canUndo());
    QVERIFY(session.undo());
    QVERIFY(session.attractionPoints(s).empty());
    QVERIFY2(positions(session) == before, "undo did not restore the meshes exactly");
    QVERIFY(session.redo());
    QCOMPARE(session.attractionPoints(s).size(), size_t(1));
    QVERIFY(nearestVertexDistance(session, s, placed) == d1);
  }

  // Include / exclude points: a click 3 mm outside the selected structure places an include point,
  // and running pushes the structure until it holds the point (winding number of its surface
  // about 1); the exclude tool places an exclude point; undo takes them back; Save Scene keeps both.
  void includeAndExcludePointsPlaceRunAndUndo() {
    SegmentationSession& session = window_->session();
    DisplayScene& display = window_->display();
    session.step(20);
    const Index s = 0;
    display.selected = s;
    const Vec3 target = beyondStructure(session, display, s, 3.0f);
    SliceView* axial = window_->sliceView(2);
    axial->invalidate();
    QApplication::processEvents();
    window_->selectTool("include_points");
    QTest::mouseClick(axial, Qt::LeftButton, {}, axial->widgetPosition(target).toPoint());
    QCOMPARE(session.constraintPoints(s).size(), size_t(1));
    const ConstraintPoint placed = session.constraintPoints(s)[0];
    QVERIFY(placed.include);
    const auto winding = [&] {
      session.syncHost();
      const TriangleMesh surface = testing::tessellationOf(session.simulation().store(), s);
      double total = 0;
      for (const auto& t : surface.triangles) {
        const Eigen::Vector3d a = (surface.points[t[0]] - placed.at).cast<double>(),
                              b = (surface.points[t[1]] - placed.at).cast<double>(),
                              c = (surface.points[t[2]] - placed.at).cast<double>();
        const double la = a.norm(), lb = b.norm(), lc = c.norm();
        total += 2 * std::atan2(a.dot(b.cross(c)), la * lb * lc + a.dot(b) * lc + b.dot(c) * la + c.dot(a) * lb);
      }
      return total / (4 * M_PI);
    };
    QVERIFY(std::abs(winding()) < 0.01);  // outside when placed
    session.step(60);
    const double after = winding();
    QVERIFY2(std::abs(after - 1.0) < 0.01, qPrintable(QString("winding number %1 after 60 steps").arg(after)));

    window_->selectTool("exclude_points");
    QTest::mouseClick(axial, Qt::LeftButton, {}, QPoint(axial->width() / 2, axial->height() / 2));
    QCOMPARE(session.constraintPoints(s).size(), size_t(2));
    QVERIFY(!session.constraintPoints(s)[1].include);
    QCOMPARE(QString::fromStdString(session.undoLabel()), QString("Add exclude point"));
    const std::filesystem::path saved = dir_.filePath("constraints.json").toStdString();
    session.saveScene(saved);
    const SceneDesc scene = readScene(saved);
    QCOMPARE(scene.structures[s].includePointsMm.size(), size_t(1));
    QCOMPARE(scene.structures[s].excludePointsMm.size(), size_t(1));
    QVERIFY(session.undo());
    QCOMPARE(session.constraintPoints(s).size(), size_t(1));
    QVERIFY(session.undo());  // the 60 steps are not an edit: this takes back the include point
    QVERIFY(session.constraintPoints(s).empty());
  }

  // The contact view's model: the session's mask is core contactMask on the current state, kept
  // while the state changes faster than the interval asked for, recomputed once it is older.
  void contactMaskFollowsTheSession() {
    SegmentationSession& session = window_->session();
    // Structures are moved by hand below: the shape guard would rightly undo that (a 50 mm drift).
    StabilityGuard noGuard = session.simulation().stabilityGuard();
    noGuard.enabled = false;
    session.simulation().setStabilityGuard(noGuard);
    // Structure 1 moved onto structure 0: a contact region for sure.
    session.syncHost();
    MeshStore& store = session.simulation().store();
    const Vec3 shift = store.positions()[store.range(0).vertexBegin] - store.positions()[store.range(1).vertexBegin];
    auto x = store.positionsForWrite();
    auto prev = store.previousPositions();
    for (Index v = store.range(1).vertexBegin; v < store.range(1).vertexEnd; ++v) x[v] += shift, prev[v] += shift;
    if (session.backend()) session.backend()->reload();
    session.step(1);
    const std::vector<unsigned char> mask = session.contactMask(0.0);
    QVERIFY(std::count(mask.begin(), mask.end(), 1) > 0);
    session.syncHost();
    // The demo scene has the collision force: the mask is drawn at its margin.
    const ParamTable& collision = session.simulation().forceParams("collision");
    const float margin = collision.getf(0, collision.indexOf("margin_mm"));
    QVERIFY(mask == contactMask(session.simulation().store(), session.simulation().scene(), margin));
    // Structure 1 taken back off structure 0: the contacts change, but within the interval asked for
    // the session keeps the last mask; asked with none, it recomputes.
    session.syncHost();
    auto back = store.positionsForWrite();
    auto backPrev = store.previousPositions();
    for (Index v = store.range(1).vertexBegin; v < store.range(1).vertexEnd; ++v) back[v] -= shift, backPrev[v] -= shift;
    if (session.backend()) session.backend()->reload();
    session.step(1);
    session.syncHost();
    const std::vector<unsigned char> now = contactMask(session.simulation().store(), session.simulation().scene(), margin);
    QVERIFY(now != mask);
    QVERIFY(session.contactMask(1e9) == mask);  // throttled: the last mask
    QVERIFY(session.contactMask(0.0) == now);
  }

  // View > Show Thickness: every vertex in the colour of its structure's medial radius, computed on
  // a background thread.
  void thicknessColoursTheSurfaces() {
    SegmentationSession& session = window_->session();
    const std::vector<float> before = session.medialRadius(0.0, true);
    QVERIFY(!session.medialRadiusPending());
    session.step(1);
    // The state moved: the call starts a job and returns at once with the last radii.
    QVERIFY(session.medialRadius(0.0) == before);
    QVERIFY(session.medialRadiusPending());
    const std::vector<float> radius = session.medialRadius(0.0, true);
    QVERIFY(!session.medialRadiusPending());
    QVERIFY(radius != before);
    MeshStore& store = session.simulation().store();
    QCOMPARE(radius.size(), std::size_t(store.vertexCount()));
    for (Index m = 0; m < store.meshCount(); ++m) {
      const auto x = store.mesh(store.positions(), m);
      const std::vector<float> core = medialRadii(tessellate(store.topologyOf(m), {x.begin(), x.end()}));
      const Index begin = store.range(m).vertexBegin;
      QVERIFY(std::equal(radius.begin() + begin, radius.begin() + begin + x.size(), core.begin()));
      const RadiusSummary r = summariseRadii(std::span<const float>(radius.data() + begin, x.size()));
      QVERIFY2(r.median > 1.0 && r.median < 10.0, qPrintable(QString("structure %1: median %2 mm").arg(m).arg(r.median)));
    }
    QAction* thickness = nullptr;
    for (QAction* a : window_->findChildren<QAction*>())
      if (a->text() == "Show &Thickness") thickness = a;
    QVERIFY(thickness);
    // The state moves again and the radii are due: the first draw starts the job, and the window
    // draws again once it has ended.
    session.step(1);
    QTest::qWait(1100);
    const QImage moved = window_->volumeView()->grabFramebuffer();
    std::vector<float> expected;
    for (Index m = 0; m < store.meshCount(); ++m) {
      const auto x = store.mesh(store.positions(), m);
      const std::vector<float> core = medialRadii(tessellate(store.topologyOf(m), {x.begin(), x.end()}));
      expected.insert(expected.end(), core.begin(), core.begin() + x.size());
    }
    thickness->trigger();
    QTRY_VERIFY_WITH_TIMEOUT(session.medialRadius(1e9) == expected, 10000);
    QTest::qWait(300);
    const QImage coloured = window_->volumeView()->grabFramebuffer();
    QCOMPARE(coloured.size(), moved.size());
    const long changed = pixelsChanged(moved, coloured);
    // The vertices are drawn as points over the surfaces: about a thousand pixels here, none before.
    QVERIFY2(changed > 300, qPrintable(QString("%1 pixels changed").arg(changed)));
    // The colour map's ends.
    QVERIFY((thicknessColour(0.5f) == std::array<unsigned char, 3>{255, 0, 0}));
    QVERIFY((thicknessColour(7.0f) == std::array<unsigned char, 3>{0, 0, 255}));
  }

  // View > Show Image Fit: every vertex in the colour of the image fit around it (core
  // vertexImageFit), throttled while the state moves; it and Show Thickness take turns.
  void imageFitColoursTheSurfaces() {
    SegmentationSession& session = window_->session();
    const std::vector<float> fit = session.vertexImageFit(0.0);
    session.syncHost();
    QVERIFY(fit == vertexImageFit(session.simulation()));
    const long scored = std::count_if(fit.begin(), fit.end(), [](float f) { return std::isfinite(f); });
    QCOMPARE(scored, long(session.simulation().store().vertexCount()));  // the scene's profile force scores all
    session.step(1);
    QVERIFY(session.vertexImageFit(1e9) == fit);  // throttled: the last fit
    QTRY_VERIFY_WITH_TIMEOUT(session.vertexImageFit(0.0) != fit, 5000);
    QVERIFY(session.vertexImageFit(0.0) == vertexImageFit(session.simulation()));
    QAction *showFit = nullptr, *thickness = nullptr;
    for (QAction* a : window_->findChildren<QAction*>()) {
      if (a->text() == "Show Image &Fit") showFit = a;
      if (a->text() == "Show &Thickness") thickness = a;
    }
    QVERIFY(showFit && thickness);
    thickness->setChecked(false);
    showFit->setChecked(false);
    window_->refreshViews();
    QTest::qWait(300);
    const QImage plain = window_->volumeView()->grabFramebuffer();
    showFit->trigger();
    QTest::qWait(300);
    const QImage coloured = window_->volumeView()->grabFramebuffer();
    QCOMPARE(coloured.size(), plain.size());
    const long changed = pixelsChanged(plain, coloured);
    QVERIFY2(changed > 300, qPrintable(QString("%1 pixels changed").arg(changed)));
    thickness->trigger();  // one colouring at a time
    QVERIFY(thickness->isChecked() && !showFit->isChecked());
    showFit->trigger();
    QVERIFY(showFit->isChecked() && !thickness->isChecked());
    showFit->trigger();
    // The colour map's ends and middle.
    QVERIFY((fitColour(0.2f) == std::array<unsigned char, 3>{255, 0, 0}));
    QVERIFY((fitColour(0.6f) == std::array<unsigned char, 3>{255, 255, 0}));
    QVERIFY((fitColour(1.0f) == std::array<unsigned char, 3>{0, 255, 0}));
  }

  void dragMovesPointInOneUndoStep() {
    SegmentationSession& session = window_->session();
    DisplayScene& display = window_->display();
    window_->selectTool("attraction_points");
    SliceView* axial = window_->sliceView(2);
    const QPointF centre(axial->width() / 2.0, axial->height() / 2.0);
    QTest::mouseClick(axial, Qt::LeftButton, {}, centre.toPoint());
    QCOMPARE(session.attractionPoints(display.selected).size(), size_t(1));
    const Vec3 first = session.attractionPoints(display.selected)[0];
    QTest::mousePress(axial, Qt::LeftButton, {}, centre.toPoint());
    // The simulation steps between the moves, as it does while running.
    for (int i = 1; i <= 5; ++i) {
      QTest::mouseMove(axial, (centre + QPointF(4 * i, 0)).toPoint());
      session.step(1);
    }
    QTest::mouseRelease(axial, Qt::LeftButton, {}, (centre + QPointF(20, 0)).toPoint());
    const Vec3 moved = session.attractionPoints(display.selected)[0];
    QVERIFY((moved - first).norm() > 1.0);
    QVERIFY(session.undo());  // the whole drag
    QVERIFY((session.attractionPoints(display.selected)[0] - first).norm() == 0.0f);
    QVERIFY(session.undo());  // the placement
    QVERIFY(session.attractionPoints(display.selected).empty());
  }

  // Landmark pairs: a drag in a slice view places one (model end where it starts, image end where it
  // ends), undo and redo step through placement and move; Simulation > Initialise from Landmarks maps
  // the model through them (a pure translation here: every vertex moves by it) and starts again.
  void landmarksPlaceUndoAndInitialise() {
    SegmentationSession& session = window_->session();
    window_->selectTool("landmarks");
    SliceView* axial = window_->sliceView(2);
    const QPoint centre(axial->width() / 2, axial->height() / 2);
    QTest::mousePress(axial, Qt::LeftButton, {}, centre);
    for (int i = 1; i <= 3; ++i) QTest::mouseMove(axial, centre + QPoint(5 * i, 0));
    QTest::mouseRelease(axial, Qt::LeftButton, {}, centre + QPoint(15, 0));
    QCOMPARE(session.landmarks().size(), size_t(1));
    const PlacedLandmark placed = session.landmarks()[0];
    QVERIFY((placed.to - placed.from).norm() > 1.0f);
    QVERIFY(std::abs(placed.to.z() - placed.from.z()) < 1e-4f);  // on the axial slice
    QVERIFY(session.undo());  // the drag
    QVERIFY((session.landmarks()[0].to - placed.from).norm() == 0.0f);
    QVERIFY(session.undo());  // the placement
    QVERIFY(session.landmarks().empty());
    QVERIFY(session.redo() && session.redo());
    QVERIFY((session.landmarks()[0].to - placed.to).norm() == 0.0f);
    // Ctrl + click on the image end removes the pair.
    QTest::mouseClick(axial, Qt::LeftButton, Qt::ControlModifier, centre + QPoint(15, 0));
    QVERIFY(session.landmarks().empty());

    QAction* initialise = nullptr;
    for (QAction* a : window_->findChildren<QAction*>())
      if (a->text() == "&Initialise from Landmarks") initialise = a;
    QVERIFY(initialise);
    window_->refreshViews();
    QVERIFY(!initialise->isEnabled());  // fewer than 4 pairs
    // Two pairs on each structure, not coplanar, all moved by the same translation.
    session.syncHost();
    const auto x = session.simulation().store().positions();
    const std::vector<Vec3> before(x.begin(), x.end());
    const Vec3 shift(2.0f, -1.0f, 1.5f);
    const MeshStore& store = session.simulation().store();
    for (Index s = 0; s < session.structureCount(); ++s) {
      const MeshRange& r = store.range(s);
      for (Index v : {r.vertexBegin, r.vertexBegin + r.vertexCount() / 2}) session.addLandmark(before[v], before[v] + shift);
    }
    window_->refreshViews();
    QVERIFY(initialise->isEnabled());
    initialise->trigger();
    QVERIFY(session.landmarks().empty());
    QVERIFY(!session.canUndo());
    QVERIFY(session.scene().initialise.method == InitialiseDesc::Method::Landmarks);
    QCOMPARE(session.scene().initialise.landmarks.size(), size_t(2 * session.structureCount()));
    session.syncHost();
    const auto after = session.simulation().store().positions();
    double worst = 0.0;
    for (size_t v = 0; v < before.size(); ++v) worst = std::max(worst, double((after[v] - before[v] - shift).norm()));
    qInfo("landmarks: every vertex moved by the pairs' translation within %.2g mm", worst);
    QVERIFY(worst < 1e-3);
  }

  // Save Scene keeps the user's points and parameter values and the schedule; the label map export
  // writes every structure's label.
  void savesSceneAndExportsLabels() {
    SegmentationSession& session = window_->session();
    const Vec3 point = window_->display().toWorld(Vec3(90, 100, 80));
    session.addAttractionPoint(1, point);
    session.setParameter("shape_prior", 1, "weight", 0.25);
    const std::filesystem::path saved = dir_.filePath("saved.json").toStdString();
    session.saveScene(saved);
    const SceneDesc s = readScene(saved);
    QCOMPARE(s.structures[1].attractionPointsMm.size(), size_t(1));
    QVERIFY(std::abs(s.structures[1].attractionPointsMm[0][0] - point.x()) < 1e-4);
    bool found = false;
    for (const auto& [force, values] : s.structures[1].forces)
      for (const auto& [name, value] : values) found |= force == "shape_prior" && name == "weight" && value == 0.25;
    QVERIFY2(found, "the structure's own shape_prior weight was not saved");
    QCOMPARE(s.schedule.size(), session.scene().schedule.size());
    for (size_t l = 0; l < s.schedule.size(); ++l) QVERIFY(s.schedule[l].forces == session.scene().schedule[l].forces);

    const std::filesystem::path labels = dir_.filePath("labels.nii.gz").toStdString();
    session.exportLabelMap(labels);
    const LabelVolume map = registry_.imageIOFor(labels).readLabels(labels);
    std::set<int> values(map.voxels().begin(), map.voxels().end());
    for (const auto& d : session.scene().structures)
      QVERIFY2(values.count(d.label), qPrintable(QString("label %1 missing").arg(d.label)));
  }

  void crosshairClickMovesOtherViews() {
    DisplayScene& display = window_->display();
    window_->selectTool("navigate");
    SliceView* axial = window_->sliceView(2);
    const auto before = display.cursor;
    QTest::mouseClick(axial, Qt::LeftButton, {}, QPoint(axial->width() / 3, axial->height() / 3));
    QVERIFY(display.cursor[0] != before[0] || display.cursor[1] != before[1]);
    QCOMPARE(display.cursor[2], before[2]);  // the axial slice itself stays
  }

  // At the end of the schedule every structure's image fit is scored into the structures table
  // (the scene's image is the model's own: every structure fits), and cleared once the meshes move.
  void imageFitShownAtTheEndOfTheSchedule() {
    window_->setRunning(true);
    QVERIFY(QTest::qWaitFor([&] { return !window_->isRunning(); }, 300000));
    QTableWidget* table = nullptr;
    for (auto* t : window_->findChildren<QTableWidget*>())
      if (t->accessibleName() == "Structures") table = t;
    QVERIFY(table);
    QCOMPARE(table->horizontalHeaderItem(4)->text(), QString("Image fit"));
    QCOMPARE(window_->session().imageFit().size(), std::size_t(4));
    for (int row = 0; row < table->rowCount(); ++row) {
      const QString text = table->item(row, 4)->text();
      qInfo("%s: image fit %s", qPrintable(table->item(row, 2)->text()), qPrintable(text));
      QVERIFY2(text.toDouble() >= kPoorImageFit && text.toDouble() <= 1.0, qPrintable(text));
    }
    window_->stepOnce();
    window_->refreshViews();
    QVERIFY(window_->session().imageFit().empty());  // never stale
    for (int row = 0; row < table->rowCount(); ++row) QVERIFY(table->item(row, 4)->text().isEmpty());
  }

  void closesCleanlyWhileRunning() {
    window_->setFollowSchedule(false);  // keeps running past the short schedule
    window_->setRunning(true);
    QTest::qWait(600);
    QVERIFY(window_->isRunning());
    QVERIFY(window_->session().simulation().iteration() > 0);
    QVERIFY(window_->close());
    QVERIFY(!window_->isRunning());
    window_.reset();  // destroys views, GL contexts and the session
  }

private:
  QTemporaryDir dir_;
  Registry registry_;
  ToolRegistry tools_;
  std::unique_ptr<MainWindow> window_;
};

int main(int argc, char** argv) {
  sinew::testing::prepareOpenGlForTests();
  QApplication app(argc, argv);
  TestWorkstation test;
  return QTest::qExec(&test, argc, argv);
}

#include "tst_workstation.moc"

// What the views draw in colours of their own (MainWindow::markers): the constraint points, and
// per vertex the thickness, the image fit or the contact regions of the View menu.
#include "main_window.h"
#include "structure_colour.h"

#include <QTimer>

#include <cmath>

namespace sinew {

std::vector<Marker> MainWindow::markers(Index s) {
  std::vector<Marker> out;
  if (!session_.isOpen()) return out;
  for (const ConstraintPoint& c : session_.constraintPoints(s))
    out.push_back({c.at, c.include ? std::array<unsigned char, 3>{60, 220, 90} : std::array<unsigned char, 3>{240, 60, 60}});
  if (showThickness_ && showThickness_->isChecked()) {
    const std::vector<float>& radius = session_.medialRadius();
    // The radii come from a background job: look again shortly while it runs.
    if (session_.medialRadiusPending() && !thicknessPoll_) {
      thicknessPoll_ = true;
      QTimer::singleShot(100, this, [this] {
        thicknessPoll_ = false;
        invalidateViews();
      });
    }
    MeshStore& store = session_.simulation().store();
    const MeshRange& r = store.range(s);
    for (Index v = r.vertexBegin; v < r.vertexEnd && v < Index(radius.size()); ++v)
      out.push_back({store.positions()[v], thicknessColour(radius[v])});
  }
  if (showFit_ && showFit_->isChecked()) {
    const std::vector<float>& fit = session_.vertexImageFit();
    MeshStore& store = session_.simulation().store();
    const MeshRange& r = store.range(s);
    for (Index v = r.vertexBegin; v < r.vertexEnd && v < Index(fit.size()); ++v)
      if (std::isfinite(fit[v])) out.push_back({store.positions()[v], fitColour(fit[v])});
  }
  if (showContacts_ && showContacts_->isChecked()) {
    const std::vector<unsigned char>& mask = session_.contactMask();
    MeshStore& store = session_.simulation().store();
    const MeshRange& r = store.range(s);
    for (Index v = r.vertexBegin; v < r.vertexEnd && v < Index(mask.size()); ++v)
      if (mask[v]) out.push_back({store.positions()[v], {255, 150, 20}});
  }
  return out;
}

}  // namespace sinew

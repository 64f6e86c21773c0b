#include "sinew/core/contact_sides.h"

#include "point_tree.h"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace sinew {

std::vector<ContactSide> countContactSides(std::span<const std::vector<Vec3>> points,
                                           std::span<const LabelVolume* const> truths, std::span<const int> labels,
                                           float reachMm) {
  const Index n = Index(points.size());
  if (Index(truths.size()) != n || Index(labels.size()) != n) throw std::logic_error("contact sides: sizes differ");
  std::vector<ContactSide> counts(size_t(n) * n);
  const float reach2 = reachMm * reachMm;
  const auto inTruth = [&](const Vec3& p, Index m) {
    const LabelVolume& t = *truths[m];
    const Vec3 idx = t.worldToIndex(p);
    if (!t.geometry().containsIndex(idx)) return false;
    const auto& s = t.geometry().size;
    const int i = std::clamp(int(std::lround(idx[0])), 0, s[0] - 1), j = std::clamp(int(std::lround(idx[1])), 0, s[1] - 1),
              k = std::clamp(int(std::lround(idx[2])), 0, s[2] - 1);
    return t.at(i, j, k) == labels[m];
  };
  // Pairs whose boxes, grown by the reach, do not meet have no contact: many structures cost their
  // far pairs a box test, not a search per point.
  std::vector<Eigen::AlignedBox3f> boxes(n);
  for (Index m = 0; m < n; ++m) {
    for (const Vec3& p : points[m]) boxes[m].extend(p);
    boxes[m].min().array() -= reachMm;
    boxes[m].max().array() += reachMm;
  }
  for (Index b = 0; b < n; ++b) {
    if (!truths[b] || points[b].empty()) continue;
    const PointCloud cloud{points[b]};
    const PointTree tree(3, cloud, nanoflann::KDTreeSingleIndexAdaptorParams(10));
    for (Index a = 0; a < n; ++a) {
      if (a == b || !truths[a] || !boxes[a].intersects(boxes[b])) continue;
      ContactSide& c = counts[size_t(a) * n + b];
      for (const Vec3& p : points[a]) {
        unsigned nearest = 0;  // nanoflann 1.4 indexes with its IndexType (unsigned)
        float d2 = 0.0f;
        tree.knnSearch(p.data(), 1, &nearest, &d2);
        if (!(d2 <= reach2)) continue;
        ++c.contact;
        c.inOtherTruth += inTruth(p, b) ? 1 : 0;
      }
    }
  }
  return counts;
}

std::vector<PairShares> sharesFromContactSides(std::span<const ContactSide> counts, Index n, Index minContacts) {
  if (Index(counts.size()) != n * n) throw std::logic_error("contact sides: expected n x n counts");
  std::vector<PairShares> out;
  for (Index a = 0; a < n; ++a)
    for (Index b = a + 1; b < n; ++b) {
      const ContactSide &ab = counts[size_t(a) * n + b], &ba = counts[size_t(b) * n + a];
      if (ab.contact < std::max<Index>(minContacts, 1) || ba.contact < std::max<Index>(minContacts, 1)) continue;
      const auto weight = [](const ContactSide& c) {
        const double o = std::max(0.05, double(c.inOtherTruth) / double(c.contact));
        return o * o;
      };
      const double wa = weight(ab), wb = weight(ba);
      out.push_back({a, b, std::min(1.0, 2.0 * wa / (wa + wb)), std::min(1.0, 2.0 * wb / (wa + wb))});
    }
  return out;
}

}  // namespace sinew

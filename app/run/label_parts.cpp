#include "label_parts.h"

#include "itk_convert.h"

#include <itkScalarConnectedComponentImageFilter.h>

#include <algorithm>
#include <map>
#include <set>
#include <string>

namespace sinew {

namespace {
// A connected part's voxels and the sum of their indices.
struct Part {
  std::size_t voxels = 0;
  Eigen::Vector3d indexSum = Eigen::Vector3d::Zero();
};
}  // namespace

std::vector<SideParts> splitBySide(LabelVolume& labels, std::span<const std::int32_t> which,
                                   std::span<const SideParts> given, const std::string& source) {
  const ImageGeometry& g = labels.geometry();
  std::vector<std::int32_t>& voxels = labels.voxels();
  // Parts of equal value, every label at once (26-connected: a part touching another only at a
  // corner is the same part, as the label surface's extraction sees it).
  using Labels = itk::Image<std::int32_t, 3>;
  using Parts = itk::Image<std::uint32_t, 3>;
  auto connect = itk::ScalarConnectedComponentImageFilter<Labels, Parts>::New();
  connect->SetInput(itkViewOf(labels));
  connect->SetDistanceThreshold(0);
  connect->SetFullyConnected(true);
  connect->Update();
  const std::uint32_t* part = connect->GetOutput()->GetBufferPointer();

  std::map<std::int32_t, std::map<std::uint32_t, Part>> partsOf;
  for (const std::int32_t v : which) partsOf[v];
  std::set<std::int32_t> inUse;  // values of the labels not split
  const std::size_t sx = std::size_t(g.size[0]), sy = std::size_t(g.size[1]);
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    const auto it = partsOf.find(voxels[i]);
    if (it == partsOf.end()) {
      if (i == 0 || voxels[i] != voxels[i - 1]) inUse.insert(voxels[i]);  // runs of one value: one insert
      continue;
    }
    Part& p = it->second[part[i]];
    ++p.voxels;
    p.indexSum += Eigen::Vector3d(double(i % sx), double((i / sx) % sy), double(i / (sx * sy)));
  }
  std::int32_t next = inUse.empty() ? 0 : *inUse.rbegin();
  for (const auto& [label, parts] : partsOf) next = std::max(next, label);
  for (const SideParts& s : given) next = std::max({next, s.left, s.right});

  const Eigen::Matrix3d toWorld = g.indexToWorldMatrix();
  const auto worldX = [&](const Eigen::Vector3d& index) { return (toWorld * index)[0]; };
  std::vector<SideParts> out;
  std::map<std::uint32_t, std::int32_t> relabel;  // part -> its side's value
  for (const auto& [label, parts] : partsOf) {
    std::size_t total = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto& [id, p] : parts) {
      total += p.voxels;
      sum += p.indexSum;
    }
    if (total == 0) continue;
    const double centreX = worldX(sum / double(total));
    std::map<std::uint32_t, bool> onLeft;
    SideParts s;
    s.label = label;
    for (const auto& [id, p] : parts) {
      onLeft[id] = worldX(p.indexSum / double(p.voxels)) > centreX;
      (onLeft[id] ? s.leftVoxels : s.rightVoxels) += p.voxels;
    }
    // Each side at least 1 - kWholeLabel of the label, so its largest part holds at most
    // kWholeLabel (less, and sinew-build-model models the label by that part) and a stray island
    // across the midline is no side.
    const double smallestSide = (1.0 - BuiltModel::kWholeLabel) * double(total);
    if (double(s.leftVoxels) < smallestSide || double(s.rightVoxels) < smallestSide) continue;
    const auto known = std::find_if(given.begin(), given.end(), [&](const SideParts& x) { return x.label == label; });
    if (known != given.end()) {
      s.left = known->left;
      s.right = known->right;
      for (const std::int32_t v : {s.left, s.right})
        if (inUse.count(v))
          throw InputError(source + ": label value " + std::to_string(v) + ", which a side of label " +
                           std::to_string(label) + " takes as in the atlas, is another label here");
    } else {
      s.left = ++next;
      s.right = ++next;
    }
    for (const auto& [id, left] : onLeft) relabel[id] = left ? s.left : s.right;
    out.push_back(s);
  }
  if (!relabel.empty())
    for (std::size_t i = 0; i < voxels.size(); ++i)
      if (const auto it = relabel.find(part[i]); it != relabel.end() && partsOf.count(voxels[i])) voxels[i] = it->second;
  return out;
}

}  // namespace sinew

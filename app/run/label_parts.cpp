#include "label_parts.h"

#include "itk_convert.h"

#include <itkScalarConnectedComponentImageFilter.h>

#include <algorithm>
#include <map>

namespace sinew {

namespace {
// A connected part's voxels and the sum of their indices.
struct Part {
  std::size_t voxels = 0;
  Eigen::Vector3d indexSum = Eigen::Vector3d::Zero();
};
}  // namespace

std::vector<SideParts> splitBySide(LabelVolume& labels, std::span<const std::int32_t> which, std::span<const SideParts> given) {
  const ImageGeometry& g = labels.geometry();
  std::vector<std::int32_t>& voxels = labels.voxels();
  // Parts of equal value, every label at once (26-connected: a part touching another only at a
  // corner is the same part, as the label surface's extraction sees it).
  using Labels = itk::Image<std::int32_t, 3>;
  using Parts = itk::Image<std::uint32_t, 3>;
  auto connect = itk::ScalarConnectedComponentImageFilter<Labels, Parts>::New();
  connect->SetInput(toItk<std::int32_t>(labels));
  connect->SetDistanceThreshold(0);
  connect->SetFullyConnected(true);
  connect->Update();
  const std::uint32_t* part = connect->GetOutput()->GetBufferPointer();

  std::map<std::int32_t, std::map<std::uint32_t, Part>> partsOf;
  for (const std::int32_t v : which) partsOf[v];
  std::int32_t largestValue = 0;
  const std::size_t sx = std::size_t(g.size[0]), sxy = sx * std::size_t(g.size[1]);
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    largestValue = std::max(largestValue, voxels[i]);
    const auto it = partsOf.find(voxels[i]);
    if (it == partsOf.end()) continue;
    Part& p = it->second[part[i]];
    ++p.voxels;
    p.indexSum += Eigen::Vector3d(double(i % sx), double((i / sx) % std::size_t(g.size[1])), double(i / sxy));
  }
  const Eigen::Matrix3d toWorld = g.indexToWorldMatrix();
  std::vector<SideParts> out;
  std::map<std::uint32_t, std::int32_t> relabel;  // part -> its side's value
  std::int32_t next = largestValue;
  for (const auto& [label, parts] : partsOf) {
    std::size_t total = 0, largest = 0;
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    for (const auto& [id, p] : parts) total += p.voxels, largest = std::max(largest, p.voxels), sum += p.indexSum;
    if (total == 0 || double(largest) >= BuiltModel::kWholeLabel * double(total)) continue;
    const double centreX = (toWorld * (sum / double(total)))[0];
    SideParts s;
    s.label = label;
    for (const auto& [id, p] : parts) ((toWorld * (p.indexSum / double(p.voxels)))[0] > centreX ? s.leftVoxels : s.rightVoxels) += p.voxels;
    if (s.leftVoxels == 0 || s.rightVoxels == 0) continue;
    const auto known = std::find_if(given.begin(), given.end(), [&](const SideParts& x) { return x.label == label; });
    s.left = known != given.end() ? known->left : ++next;
    s.right = known != given.end() ? known->right : ++next;
    for (const auto& [id, p] : parts) relabel[id] = (toWorld * (p.indexSum / double(p.voxels)))[0] > centreX ? s.left : s.right;
    out.push_back(s);
  }
  if (!relabel.empty())
    for (std::size_t i = 0; i < voxels.size(); ++i)
      if (const auto it = relabel.find(part[i]); it != relabel.end() && partsOf.count(voxels[i])) voxels[i] = it->second;
  return out;
}

}  // namespace sinew

#include "label_parts.h"

#include "itk_convert.h"
#include "sinew/core/model_file.h"
#include "sinew/core/types.h"

#include <nlohmann/json.hpp>

#include <itkScalarConnectedComponentImageFilter.h>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <map>
#include <optional>
#include <string>

namespace sinew {

namespace {
// A connected part's voxels and the sum of their indices.
struct Part {
  std::size_t voxels = 0;
  Eigen::Vector3d indexSum = Eigen::Vector3d::Zero();
};

// The label's left-right axis, pointing to the subject's left (+x in LPS), if its parts lie on
// both sides of the midline: from its largest part to the largest other part such that the two
// lie across the brain's centre (the centre of every labelled voxel projects between them, within
// the middle half) along an axis within 60 degrees of world x. So a head turned by up to 60 degrees
// still splits (a plane along world x cut turned labels at the wrong place), while a label in one
// hemisphere, in parts one behind the other, does not.
template <class CentreOf>
std::optional<Eigen::Vector3d> sideAxis(const std::map<std::uint32_t, Part>& parts, const CentreOf& centreOf,
                                        const Eigen::Vector3d& brainCentre) {
  std::vector<const Part*> bySize;
  for (const auto& [id, p] : parts) bySize.push_back(&p);
  std::stable_sort(bySize.begin(), bySize.end(), [](const Part* a, const Part* b) { return a->voxels > b->voxels; });
  if (bySize.size() < 2) return std::nullopt;
  const Eigen::Vector3d largest = centreOf(*bySize[0]);
  for (size_t k = 1; k < bySize.size(); ++k) {
    const Eigen::Vector3d d = largest - centreOf(*bySize[k]);
    const double length2 = d.squaredNorm();
    if (length2 == 0.0 || std::abs(d.x()) < 0.5 * std::sqrt(length2)) continue;  // not across: within 60 degrees of x
    const double t = (brainCentre - centreOf(*bySize[k])).dot(d) / length2;   // 0 at part k, 1 at the largest
    if (t < 0.25 || t > 0.75) continue;
    return d.x() > 0.0 ? d / std::sqrt(length2) : Eigen::Vector3d(-d / std::sqrt(length2));
  }
  return std::nullopt;
}
}  // namespace

std::vector<SideParts> splitBySide(LabelVolume& labels, std::span<const std::int32_t> which, std::int32_t floor) {
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
  std::int32_t next = floor;  // new values from above every value in use
  Part labelled;              // every labelled voxel: their centre is the brain's
  const std::size_t sx = std::size_t(g.size[0]), sy = std::size_t(g.size[1]);
  for (std::size_t i = 0; i < voxels.size(); ++i) {
    if (voxels[i] == 0) continue;
    next = std::max(next, voxels[i]);
    const Eigen::Vector3d index(double(i % sx), double((i / sx) % sy), double(i / (sx * sy)));
    ++labelled.voxels;
    labelled.indexSum += index;
    const auto it = partsOf.find(voxels[i]);
    if (it == partsOf.end()) continue;
    Part& p = it->second[part[i]];
    ++p.voxels;
    p.indexSum += index;
  }
  if (labelled.voxels == 0) return {};
  const Eigen::Matrix3d toWorld = g.indexToWorldMatrix();
  const auto centreOf = [&](const Part& p) -> Eigen::Vector3d { return toWorld * (p.indexSum / double(p.voxels)); };
  const Eigen::Vector3d brainCentre = centreOf(labelled);
  std::vector<SideParts> out;
  std::map<std::uint32_t, std::int32_t> relabel;  // part -> its side's value
  for (const auto& [label, parts] : partsOf) {
    const std::optional<Eigen::Vector3d> leftward = sideAxis(parts, centreOf, brainCentre);
    if (!leftward) continue;
    SideParts s;
    s.label = label;
    std::map<std::uint32_t, bool> onLeft;
    for (const auto& [id, p] : parts) {
      onLeft[id] = leftward->dot(centreOf(p) - brainCentre) > 0.0;
      (onLeft[id] ? s.leftVoxels : s.rightVoxels) += p.voxels;
    }
    // Each side at least 1 - kWholeLabel of the label, so its largest part holds at most
    // kWholeLabel (less, and sinew-build-model models the label by that part) and a stray island
    // across the midline is no side. The midline: the plane through the brain's centre across
    // the label's left-right axis.
    const double smallestSide = (1.0 - BuiltModel::kWholeLabel) * double(s.leftVoxels + s.rightVoxels);
    if (s.leftVoxels + s.rightVoxels == 0 || double(s.leftVoxels) < smallestSide || double(s.rightVoxels) < smallestSide)
      continue;
    s.left = ++next;
    s.right = ++next;
    for (const auto& [id, left] : onLeft) relabel[id] = left ? s.left : s.right;
    out.push_back(s);
  }
  if (!relabel.empty())
    for (std::size_t i = 0; i < voxels.size(); ++i)
      if (const auto it = relabel.find(part[i]); it != relabel.end() && partsOf.count(voxels[i])) voxels[i] = it->second;
  return out;
}

std::vector<SideParts> splitTruthBySide(LabelVolume& truth, std::span<const std::int32_t> labels, std::int32_t floor,
                                        const std::string& file, const std::string& splitIn) {
  std::vector<SideParts> made = splitBySide(truth, labels, floor);
  for (const std::int32_t label : labels)
    if (std::none_of(made.begin(), made.end(), [&](const SideParts& p) { return p.label == label; }))
      throw InputError(file + ": label " + std::to_string(label) + " is not in parts on both sides here, as it is in the " +
                       splitIn + "; it cannot be split alike");
  checkSideValues(made, file);
  return made;
}

void checkSideValues(std::span<const SideParts> made, const std::string& file) {
  for (const SideParts& p : made)
    if (std::max(p.left, p.right) > kLargestLabelValue)
      throw InputError(file + ": no label value left for the sides of label " + std::to_string(p.label) + " (values run to " +
                       std::to_string(kLargestLabelValue) + ")");
}

std::map<std::string, bool> sidesOfModel(const std::filesystem::path& model) {
  std::map<std::string, bool> out;
  const std::filesystem::path manifest = model / "model.json";
  std::ifstream in(manifest);
  const nlohmann::json m = nlohmann::json::parse(in, nullptr, false);
  if (m.is_discarded() || !m.is_object() || !m.contains("structures") || !m["structures"].is_array()) return out;
  for (const nlohmann::json& s : m["structures"])
    if (s.is_object() && s.contains("name") && s["name"].is_string() && s.contains("side")) {
      const std::string name = s["name"].get<std::string>();
      out[name] = isLeftSide(s["side"].is_string() ? s["side"].get<std::string>() : s["side"].dump(),
                             manifest.string() + ": structure '" + name + "'");
    }
  return out;
}

}  // namespace sinew

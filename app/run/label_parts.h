// A label in parts apart from each other (a parcel of both hemispheres, as in Harvard-Oxford's
// cortical atlas or AICHA) as two labels, one for each side. A model is one closed surface, so such
// a label is otherwise modelled by its largest part and scored against all of it (docs/accuracy.md,
// "Atlases of other kinds"); split, each side is a structure of its own (sinew-make-scene
// --split-parts).
#pragma once

#include "sinew/core/io.h"
#include "sinew/core/model_builder.h"

#include <cstdint>
#include <filesystem>
#include <map>
#include <span>
#include <string>
#include <vector>

namespace sinew {

// A label's two sides and the new values they took.
struct SideParts {
  std::int32_t label = 0, left = 0, right = 0;
  std::size_t leftVoxels = 0, rightVoxels = 0;
};

// Splits, in place, each label of `which` whose connected parts (26-connected) lie on both sides
// of the midline, each side with at least 1 - BuiltModel::kWholeLabel of its voxels: the left
// parts take the value `left`, the right ones `right`. The label's left-right axis runs from its
// largest part to the largest other part that lies across the brain's centre (the centre of
// every labelled voxel of the map projects between the two, in the middle half) along an axis
// within 60 degrees of world x; it points to the larger x (LPS: the subject's left). The midline
// is the plane through the brain's centre across that axis; each part lies on the side its own
// centre does. So a head turned by up to 60 degrees splits as an upright one, a split label's
// largest part holds at most kWholeLabel of it (where sinew-build-model would model it by that
// part alone), a stray island across the midline is no side, and a label in one hemisphere is not
// split. New values are given from above the map's largest value and `floor` (the values of the
// labels a scene scores against, whether or not this map holds them). Labels that stay whole, or
// whose parts lie on one side, are not in the result.
std::vector<SideParts> splitBySide(LabelVolume& labels, std::span<const std::int32_t> which, std::int32_t floor = 0);

// The largest value a label map written by Sinew may hold (16-bit maps).
inline constexpr std::int32_t kLargestLabelValue = 32767;

// A subject's ground truth (read from `file`) split so: every label of `labels` must split, as it
// did in the atlas or the model (`splitIn`), and the new values must fit a written label map; an
// InputError naming the file otherwise.
std::vector<SideParts> splitTruthBySide(LabelVolume& truth, std::span<const std::int32_t> labels, std::int32_t floor,
                                        const std::string& file, const std::string& splitIn);

// The sides' new values fit a written label map; an InputError naming `file` otherwise.
void checkSideValues(std::span<const SideParts> made, const std::string& file);

// The structures of a model (its folder) that are one side of a label: name -> left (true) or
// right. Only the manifest is read; one that cannot be read has none (sinew-run names its
// problem); a "side" that is neither is an InputError naming the manifest.
std::map<std::string, bool> sidesOfModel(const std::filesystem::path& model);

}  // namespace sinew

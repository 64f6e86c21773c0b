// A label in parts apart from each other (a parcel of both hemispheres, as in Harvard-Oxford's
// cortical atlas or AICHA) as two labels, one for each side. A model is one closed surface, so such
// a label is otherwise modelled by its largest part and scored against all of it (docs/accuracy.md,
// "Atlases of other kinds"); split, each side is a structure of its own (sinew-make-scene
// --split-parts).
#pragma once

#include "sinew/core/io.h"
#include "sinew/core/model_builder.h"

#include <cstdint>
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
// of the label's centre along world x, each side with at least 1 - BuiltModel::kWholeLabel of its
// voxels (each part on the side of its own centre; LPS, so +x is the subject's left): the left
// parts take the value `left`, the right ones `right`. So a split label's largest part holds at
// most kWholeLabel of it (where sinew-build-model would model it by that part alone), and a stray
// island across the midline is no side. New values are given from the largest value in the map
// up, or, where `given` names the label (a ground truth split as its atlas was), its values; a
// given value that another label of the map holds already is an InputError naming `source`.
// Labels that stay whole, or whose parts lie on one side, are not in the result.
std::vector<SideParts> splitBySide(LabelVolume& labels, std::span<const std::int32_t> which,
                                   std::span<const SideParts> given, const std::string& source);

}  // namespace sinew

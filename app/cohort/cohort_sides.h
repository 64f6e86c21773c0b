// A cohort on a model with labels split by side (sinew-build-model --split-parts): each subject's
// ground truth split alike, so that each side is scored against its own side.
#pragma once

#include "sinew/core/io.h"
#include "sinew/core/registry.h"

#include <filesystem>
#include <optional>

#include <nlohmann/json.hpp>  // ordered_json, as the cohort's scenes

namespace sinew::cohort {

// The scene's structures that are one side of a label in the model the scene names; where the
// subject's scene scores any of them against a ground truth, that truth is read through
// `registry` and split by side (sinew::splitTruthBySide: the side's label there is the model's
// label, the structure's "label"), every structure's ground truth pointed at `partsFile` and each side's label
// set to its side's value there, and the split map returned for the caller to write to
// `partsFile`. Nothing to split: nullopt, the scene unchanged. A truth whose label is not in parts
// on both sides is an InputError naming the file.
std::optional<LabelVolume> splitTruthBySide(const Registry& registry, nlohmann::ordered_json& scene,
                                            const std::filesystem::path& partsFile);

}  // namespace sinew::cohort

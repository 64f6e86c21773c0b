// Atlas label lists as shipped with atlases (aal.nii.txt: "value name [code]" per line), shared by
// sinew-make-scene and sinew-build-model.
#pragma once

#include <filesystem>
#include <string>
#include <vector>

namespace sinew {

struct LabelEntry {
  int value = 0;
  std::string name;
};

// Throws InputError naming the file (and line) when it cannot be read or parsed.
std::vector<LabelEntry> readLabelList(const std::filesystem::path& path);
// The entry whose name or value is `key`; throws InputError naming the list otherwise.
const LabelEntry& findLabel(const std::vector<LabelEntry>& list, const std::string& key, const std::filesystem::path& file);
// For an atlas without a label list (Harvard-Oxford's, Brodmann's): each key must be a label value
// ("37"), named "label_37"; throws InputError naming the first key that is not.
std::vector<LabelEntry> unnamedLabels(const std::vector<std::string>& keys);
// "a,b,,c" -> {"a", "b", "c"}.
std::vector<std::string> splitList(const std::string& s);

// The 12 AAL subcortical structures of the Colin27 demo.
inline constexpr const char* kDefaultStructures =
    "Hippocampus_L,Hippocampus_R,Amygdala_L,Amygdala_R,Caudate_L,Caudate_R,Putamen_L,Putamen_R,Pallidum_L,"
    "Pallidum_R,Thalamus_L,Thalamus_R";

}  // namespace sinew

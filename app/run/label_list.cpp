#include "label_list.h"

#include "sinew/core/types.h"

#include <charconv>
#include <fstream>
#include <sstream>

namespace sinew {

std::vector<LabelEntry> readLabelList(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string() + ": cannot open the label list");
  std::vector<LabelEntry> out;
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    std::istringstream s(line);
    LabelEntry e;
    if (!(s >> e.value >> e.name)) throw InputError(path.string() + ":" + std::to_string(lineNo) + ": expected 'value name'");
    out.push_back(e);
  }
  return out;
}

const LabelEntry& findLabel(const std::vector<LabelEntry>& list, const std::string& key, const std::filesystem::path& file) {
  for (const auto& e : list)
    if (e.name == key || std::to_string(e.value) == key) return e;
  throw InputError(file.string() + ": no label named or numbered '" + key + "'");
}

std::vector<LabelEntry> unnamedLabels(const std::vector<std::string>& keys) {
  std::vector<LabelEntry> out;
  for (const std::string& key : keys) {
    int value = 0;
    const auto [end, error] = std::from_chars(key.data(), key.data() + key.size(), value);
    if (error != std::errc() || end != key.data() + key.size() || std::to_string(value) != key)
      throw InputError("--structures: '" + key + "' is not a label value; without --labels (a list naming the atlas's " +
                       "labels) give the structures as label values, such as 37,38");
    out.push_back({value, "label_" + key});
  }
  return out;
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace sinew

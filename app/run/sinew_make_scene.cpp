// sinew-make-scene: writes a segmentation scene from an atlas. Reference shapes come from the
// atlas labels, profiles are trained on one image and another is segmented; each initial mesh is
// its reference moved by a seeded random similarity transform, and the atlas is the ground truth.
#include "sinew/core/scene.h"
#include "sinew/core/io.h"
#include "sinew/core/types.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <cmath>
#include <fstream>
#include <iostream>
#include <random>
#include <sstream>

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;

namespace {

struct LabelEntry {
  int value;
  std::string name;
};

// Label lists as shipped with atlases (aal.nii.txt): "value name [code]" per line.
std::vector<LabelEntry> readLabelList(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw sinew::InputError(path.string() + ": cannot open the label list");
  std::vector<LabelEntry> out;
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (line.find_first_not_of(" \t\r") == std::string::npos || line[0] == '#') continue;
    std::istringstream s(line);
    LabelEntry e;
    if (!(s >> e.value >> e.name))
      throw sinew::InputError(path.string() + ":" + std::to_string(lineNo) + ": expected 'value name'");
    out.push_back(e);
  }
  return out;
}

const LabelEntry& findLabel(const std::vector<LabelEntry>& list, const std::string& key, const fs::path& file) {
  for (const auto& e : list)
    if (e.name == key || std::to_string(e.value) == key) return e;
  throw sinew::InputError(file.string() + ": no label named or numbered '" + key + "'");
}

std::vector<std::string> splitList(const std::string& s) {
  std::vector<std::string> out;
  std::stringstream in(s);
  std::string item;
  while (std::getline(in, item, ','))
    if (!item.empty()) out.push_back(item);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"sinew-make-scene: write a segmentation scene from an atlas label map."};
  std::string atlas, labelList, training, target, groundTruth, output = "scene.json";
  std::string structures =
      "Hippocampus_L,Hippocampus_R,Amygdala_L,Amygdala_R,Caudate_L,Caudate_R,Putamen_L,Putamen_R,Pallidum_L,"
      "Pallidum_R,Thalamus_L,Thalamus_R";
  std::string iterations = "150,80,30";
  unsigned seed = 1;
  double maxRotation = 8.0, maxTranslation = 3.0, scaleMin = 0.9, scaleMax = 1.1, coarseSpacing = 4.0;
  cli.add_option("--atlas", atlas, "atlas label map: reference shapes (and ground truth by default)")->required();
  cli.add_option("--labels", labelList, "label list of the atlas, 'value name' per line")->required();
  cli.add_option("--structures", structures, "comma-separated label names or values")->capture_default_str();
  cli.add_option("--training", training, "image the intensity profiles are trained on")->required();
  cli.add_option("--target", target, "image to segment")->required();
  cli.add_option("--ground-truth", groundTruth, "label map to score against (default: the atlas)");
  cli.add_option("--seed", seed, "seed of the random placement")->capture_default_str();
  cli.add_option("--max-rotation-deg", maxRotation, "largest rotation")->capture_default_str();
  cli.add_option("--max-translation-mm", maxTranslation, "largest translation")->capture_default_str();
  cli.add_option("--scale-min", scaleMin, "smallest scale")->capture_default_str();
  cli.add_option("--scale-max", scaleMax, "largest scale")->capture_default_str();
  cli.add_option("--iterations", iterations, "iterations per level, coarse to fine (its length = levels)")
      ->capture_default_str();
  cli.add_option("--coarse-spacing-mm", coarseSpacing, "vertex spacing at the coarsest level")->capture_default_str();
  cli.add_option("-o,--output", output, "scene file to write")->capture_default_str();
  cli.set_version_flag("--version", std::string("sinew-make-scene ") + SINEW_VERSION);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (!(scaleMin > 0 && scaleMin <= scaleMax)) throw sinew::InputError("--scale-min/--scale-max: need 0 < min <= max");
    auto absolute = [](const std::string& p) { return fs::absolute(p).lexically_normal().string(); };
    for (const auto& p : {atlas, labelList, training, target})
      if (!fs::exists(p)) throw sinew::InputError(p + ": no such file");
    const auto list = readLabelList(labelList);
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> unit(0.0, 1.0);
    std::normal_distribution<double> gauss(0.0, 1.0);
    auto direction = [&] {
      Eigen::Vector3d d(gauss(rng), gauss(rng), gauss(rng));
      return d.normalized();
    };

    Json scene;
    scene["version"] = sinew::kSceneVersion;
    std::ostringstream desc;
    desc << "made by sinew-make-scene --seed " << seed << " --max-rotation-deg " << maxRotation
         << " --max-translation-mm " << maxTranslation << " --scale-min " << scaleMin << " --scale-max " << scaleMax;
    scene["description"] = desc.str();
    scene["images"] = {{"target", absolute(target)}, {"training", absolute(training)}};
    Json items = Json::array();
    for (const std::string& key : splitList(structures)) {
      const LabelEntry& e = findLabel(list, key, labelList);
      const Eigen::Vector3d axis = direction(), shift = direction() * (maxTranslation * unit(rng));
      Json s;
      s["name"] = e.name;
      s["label"] = e.value;
      s["reference"] = {{"label_map", absolute(atlas)}, {"label", e.value}};
      s["initial"] = {{"rotation_axis", {axis.x(), axis.y(), axis.z()}},
                      {"rotation_deg", maxRotation * unit(rng)},
                      {"translation_mm", {shift.x(), shift.y(), shift.z()}},
                      {"scale", scaleMin + (scaleMax - scaleMin) * unit(rng)}};
      s["ground_truth"] = {{"label_map", absolute(groundTruth.empty() ? atlas : groundTruth)}, {"label", e.value}};
      items.push_back(s);
    }
    scene["structures"] = items;
    // Forces and schedule tuned on the Colin27 demo (docs/demo.md): a strong shape prior keeps each
    // structure's shape while gentle profile forces move it; a trace of smoothing keeps it regular.
    scene["forces"] = {
        {"smoothing", {{"weight", 0.02}}},
        {"shape_prior", {{"weight", 1.0}}},
        {"intensity_profile", {{"weight", 0.2}, {"inside_samples", 25}, {"outside_samples", 5}, {"spacing", 0.5}}}};
    scene["integrator"] = {{"name", "damped_verlet"}, {"time_step", 0.5}, {"damping", 0.6}};
    const auto counts = splitList(iterations);
    if (counts.empty() || counts.size() > 6) throw sinew::InputError("--iterations: give 1 to 6 counts");
    Json schedule = Json::array();
    for (size_t l = 0; l < counts.size(); ++l) {
      const double depth = std::max(1.0, 4.0 / std::pow(2.0, double(l)));  // search depth decreases (paper 001)
      schedule.push_back({{"iterations", std::stoi(counts[l])}, {"forces", {{"intensity_profile", {{"search_depth", depth}}}}}});
    }
    scene["schedule"] = schedule;
    scene["model"] = {{"coarse_spacing_mm", coarseSpacing}};
    scene["report"] = {{"sample_interval", 10}, {"surface_sample_spacing_mm", 0.5}};
    scene["outputs"] = {{"mesh_format", ".vtp"}, {"meshes", true}, {"label_map", "segmentation.nii.gz"}};

    const fs::path out(output);
    if (out.has_parent_path()) fs::create_directories(out.parent_path());
    sinew::AtomicOutput file(out);
    {
      std::ofstream f(file.tempPath());
      f << scene.dump(2) << "\n";
      if (!f) throw sinew::InputError(output + ": cannot write the scene");
    }
    file.commit();
    std::cerr << "wrote " << output << " (" << items.size() << " structures, seed " << seed << ")\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "sinew-make-scene: error: " << e.what() << "\n";
    return 3;
  }
}

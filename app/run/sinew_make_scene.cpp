// sinew-make-scene: writes a segmentation scene from an atlas or a model. Demo mode: reference
// shapes from the atlas labels, profiles trained on one image and another segmented; each initial
// mesh is its reference moved by a seeded random similarity, and the atlas is the ground truth.
// Subject mode (--subject, implied by --model): a new subject's image, the model placed by
// registering its atlas image to the target, no perturbation, a ground truth only when given.
#include "builtin_plugins.h"
#include "collision_share_learning.h"
#include "label_list.h"
#include "label_parts.h"
#include "sinew/core/scene.h"
#include "sinew/core/io.h"
#include "sinew/core/types.h"

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <optional>
#include <random>
#include <span>
#include <sstream>

namespace fs = std::filesystem;
using Json = nlohmann::ordered_json;
using namespace sinew;


namespace {
// A registered model starts near its boundaries, and at the coarsest level (the image forces
// fully replaced by their closest affine field, a 2 mm search) further steps mostly let a structure
// drift to another edge: subject 701 (a harder warp) went from 0.94 to 1.73 mm for Thalamus_L over
// 150. Fewer were better on every subject of the sweep in docs/accuracy.md (chosen on seeds
// 601-606 and 701-703, checked on 201-205). The demo starts from a random placement instead and
// keeps its 150. At the finest level (a 0.5 mm search, 20 % affine) the structures were still
// settling after 30: 50 ended better on 35 of 36 subjects and let none drift (docs/accuracy.md,
// "More iterations at the finest level"); more at level 1 let some drift.
constexpr const char* kDemoIterations = "150,80,30";
constexpr const char* kSubjectIterations = "50,80,50";
// Deforming contacts (paper 001 section 2.2) between every pair of structures in subject mode: the
// registered model's relative placement held by springs at the coarser levels, released at the
// finest. On 36 new subjects 31 ended better, the harder ones most (docs/collisions.md, "Deforming
// contacts on new subjects"); 0.3 and 1 were about as good, and the gentler one was taken, since
// real subjects' structures sit less like the atlas's than these warped copies of it do.
constexpr double kSubjectContactWeight = 0.3;
// The collision's reaction gain (its parameter `reaction`): 2 against 1 and 4 on the CPU over 32
// scenes; 4 left more overlap on the occipital-temporal set (docs/collisions.md, "The reaction").
constexpr double kCollisionReaction = 2.0;
// With the reaction, the sharing's exponent (`size_share`, the force's default 2): 4 against 2 over
// every structure set on both backends (H200, 2026-12-02) cost 0.0008-0.0013 mm less ASSD on the
// 42 new subjects and less on 7 of 9 sets; the overlap left stayed at most 1.5 mm^3 on every set but
// the occipital-temporal one, which it lowered on the CPU (docs/collisions.md, "The sharing's
// exponent with the reaction").
constexpr double kCollisionSizeShare = 4.0;
// At the finest level the springs are kept at a third of that weight rather than released (the
// paper releases them): over 23 subjects not used to choose it the mean ASSD fell by 0.0034 mm,
// 20 better, the harder subjects most, at no measurable cost in time (docs/collisions.md, "The
// deforming contacts kept at the finest level").
constexpr double kFinestContactShare = 1.0 / 3.0;
}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"sinew-make-scene: write a segmentation scene from an atlas label map or a model."};
  std::string atlas, labelList, training, target, groundTruth, output = "scene.json", model, transform;
  std::string structures = kDefaultStructures;
  std::string iterations, initialise = "bspline";  // iterations: kDemoIterations or kSubjectIterations
  bool subject = false, splitParts = false;
  unsigned seed = 1;
  double maxRotation = 8.0, maxTranslation = 3.0, scaleMin = 0.9, scaleMax = 1.1, coarseSpacing = 4.0;
  double collisionWeight = 1.0, collisionMargin = 0.15, contactWeight = -1.0;  // contacts: the mode's default
  int collisionLevels = 0, collisionSearchEvery = 0;
  std::vector<std::string> sharesFrom;
  int sharesMinContacts = 100;
  cli.add_option("--atlas", atlas, "atlas label map: reference shapes (and, in demo mode, the ground truth)");
  cli.add_option("--labels", labelList,
                 "label list of the atlas, 'value name' per line (without it, --structures are label values, named label_VALUE)");
  cli.add_option("--model", model, "a model folder (sinew-build-model) instead of --atlas/--labels/--training; implies --subject");
  cli.add_flag("--subject", subject, "subject mode: no random perturbation, the model initialised by registration, "
                                     "a ground truth only from --ground-truth");
  cli.add_option("--initialise", initialise, "subject mode: registration of the atlas image to the target")
      ->check(CLI::IsMember({"bspline", "affine", "rigid", "none"}))->capture_default_str();
  cli.add_option("--transform", transform, "subject mode: an ITK transform file (target to model) instead of registering");
  auto* structuresOption = cli.add_option("--structures", structures,
                                          "comma-separated label names or values (default with --model: all of its structures)")
                               ->capture_default_str();
  cli.add_option("--training", training, "image the intensity profiles are trained on (default with --model: its atlas)");
  cli.add_option("--target", target, "image to segment")->required();
  cli.add_option("--ground-truth", groundTruth, "label map to score against (demo mode default: the atlas)");
  cli.add_flag("--split-parts", splitParts,
               "a label in parts apart from each other on both sides (a parcel of both hemispheres) becomes two "
               "structures, NAME_L and NAME_R, each modelled and scored on its own side; the split label maps are "
               "written beside the scene (SCENE.atlas-parts.nii.gz, SCENE.truth-parts.nii.gz), the output label "
               "map keeps the label's value");
  cli.add_option("--seed", seed, "seed of the random placement")->capture_default_str();
  cli.add_option("--max-rotation-deg", maxRotation, "largest rotation")->capture_default_str();
  cli.add_option("--max-translation-mm", maxTranslation, "largest translation")->capture_default_str();
  cli.add_option("--scale-min", scaleMin, "smallest scale")->capture_default_str();
  cli.add_option("--scale-max", scaleMax, "largest scale")->capture_default_str();
  cli.add_option("--iterations", iterations,
                 std::string("iterations per level, coarse to fine (its length = levels; default ") + kDemoIterations +
                     " in demo mode, " + kSubjectIterations + " in subject mode)");
  cli.add_option("--coarse-spacing-mm", coarseSpacing, "vertex spacing at the coarsest level")->capture_default_str();
  cli.add_option("--collision-weight", collisionWeight,
                 "weight of the collision force on the levels that collide (--collision-levels), for scenes of two "
                 "or more structures (0: off)")
      ->check(CLI::Range(0.0, 1.0))->capture_default_str();
  cli.add_option("--collision-levels", collisionLevels,
                 "how many of the finest levels collide (default: 1 in subject mode; in demo mode every level but "
                 "the coarsest, at least 2)")
      ->check(CLI::Range(1, 6));
  cli.add_option("--collision-margin-mm", collisionMargin, "distance the collision force keeps between structures")
      ->check(CLI::Range(0.0, 5.0))->capture_default_str();
  cli.add_option("--collision-search-every", collisionSearchEvery,
                 "a full contact search every this many steps, contact planes in between (default 16; schedules of "
                 "5 levels or more also search in full at each level's first 8 steps and hold a vertex out by at "
                 "most 0.05 of its spacing a step)")
      ->check(CLI::Range(1, 16));
  cli.add_option("--collision-shares-from", sharesFrom,
                 "folder of a finished sinew-run of a labelled subject without collisions (repeatable): the "
                 "collision's shares by pair learned from them, the side of each pair that reached into the "
                 "other's truth giving way (docs/collisions.md, \"Shares by pair, learned\")");
  cli.add_option("--collision-shares-min-contacts", sharesMinContacts,
                 "contact points each side of a pair needs, over those runs, for its shares")
      ->check(CLI::Range(1, 1000000))->capture_default_str();
  cli.add_option("--contact-weight", contactWeight,
                 "weight of the deforming contacts (springs keeping the initialised model's relative placement of "
                 "structures within 2 mm of each other) at every level but the finest, and a third of it at the "
                 "finest, for scenes of two or more structures (default: " +
                     [] { std::ostringstream o; o << kSubjectContactWeight; return o.str(); }() +
                     " in subject mode, 0 in demo mode; 0: off)")
      ->check(CLI::Range(0.0, 1.0));  // the force's weight, as every force's, is in [0, 1]
  cli.add_option("-o,--output", output, "scene file to write")->capture_default_str();
  cli.set_version_flag("--version", std::string("sinew-make-scene ") + SINEW_VERSION);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  }
  try {
    if (!(scaleMin > 0 && scaleMin <= scaleMax)) throw sinew::InputError("--scale-min/--scale-max: need 0 < min <= max");
    subject = subject || !model.empty();
    if (iterations.empty()) iterations = subject ? kSubjectIterations : kDemoIterations;
    if (model.empty() && (atlas.empty() || training.empty()))
      throw sinew::InputError("give --atlas and --training (and --labels to name the atlas's labels), or --model");
    if (!model.empty() && !atlas.empty()) throw sinew::InputError("give --atlas or --model, not both");
    if (!subject && !transform.empty()) throw sinew::InputError("--transform goes with --subject or --model");
    auto absolute = [](const std::string& p) { return fs::absolute(p).lexically_normal().string(); };
    for (const auto& p : {atlas, labelList, training, target, groundTruth, transform})
      if (!p.empty() && !fs::exists(p)) throw sinew::InputError(p + ": no such file");
    if (target.empty()) throw sinew::InputError("--target: the image to segment is required");
    // In subject mode the structures are those of the model (or the atlas), named as in it.
    std::vector<LabelEntry> list;
    std::map<std::string, bool> leftOf;  // a model's structures that are one side of a label (sinew-build-model --split-parts)
    if (!model.empty()) {
      // Only the manifest is read here: the names and labels of the model's structures.
      std::ifstream in(fs::path(model) / "model.json");
      if (!in) throw sinew::InputError(model + ": not a Sinew model (no model.json)");
      const Json m = Json::parse(in, nullptr, false);
      if (m.is_discarded() || !m.contains("structures"))
        throw sinew::InputError((fs::path(model) / "model.json").string() + ": not a valid model manifest");
      for (const auto& s : m["structures"]) list.push_back({s.value("label", 0), s.value("name", std::string())});
      leftOf = sidesOfModel(model);
      if (structuresOption->count() == 0) {
        structures.clear();
        for (const LabelEntry& e : list) structures += (structures.empty() ? "" : ",") + e.name;
      }
    } else {
      list = labelList.empty() ? unnamedLabels(splitList(structures)) : readLabelList(labelList);
    }
    if (splitParts && !model.empty())
      throw sinew::InputError("--split-parts goes with --atlas: a model's structures are built already "
                              "(sinew-build-model --split-parts splits its labels)");
    const fs::path listFile = model.empty() ? fs::path(labelList) : fs::path(model) / "model.json";
    // The structures asked for, each once. Of a model's sides, a key that is the label's value or
    // name takes both.
    std::vector<const LabelEntry*> chosen;
    const auto choose = [&](const LabelEntry* e) {
      if (std::find(chosen.begin(), chosen.end(), e) == chosen.end()) chosen.push_back(e);
    };
    for (const std::string& key : splitList(structures)) {
      const auto exact = std::find_if(list.begin(), list.end(), [&](const LabelEntry& e) { return e.name == key; });
      bool sides = false;
      if (exact == list.end())
        for (const LabelEntry& e : list)
          if (leftOf.count(e.name) && (e.name == key + "_L" || e.name == key + "_R" || std::to_string(e.value) == key)) {
            choose(&e);
            sides = true;
          }
      if (!sides) choose(&findLabel(list, key, listFile));
    }
    // New values for the sides from above every label the scene scores against.
    std::int32_t floor = 0;
    for (const LabelEntry* e : chosen) floor = std::max(floor, std::int32_t(e->value));
    // The labels in parts, split by side into maps beside the scene (atomically, like the scene):
    // the atlas's and a subject's truth with --split-parts, a subject's truth for a model's sides.
    // Each map's sides take values of its own.
    const fs::path sceneOut(output);
    std::vector<SideParts> splits, truthSplits;
    std::string atlasMap = atlas.empty() ? atlas : absolute(atlas), truthMap = groundTruth.empty() ? atlasMap : absolute(groundTruth);
    std::vector<std::unique_ptr<sinew::AtomicOutput>> partMaps;
    Registry registry;
    PluginLoader plugins(registry);
    addBuiltinPlugins(plugins);
    // A split map written beside the scene, its path returned.
    const auto writeBeside = [&](const std::string& suffix, const LabelVolume& labels) {
      fs::path partsFile = sceneOut;
      partsFile.replace_extension(suffix);
      if (partsFile.has_parent_path()) fs::create_directories(partsFile.parent_path());
      partMaps.push_back(std::make_unique<sinew::AtomicOutput>(absolute(partsFile.string())));
      registry.imageIOFor(partsFile).writeLabels(partMaps.back()->tempPath(), labels);
      return absolute(partsFile.string());
    };
    // The subject's truth: every label of `labels` split, as it is in the atlas or the model.
    const auto splitTruth = [&](std::span<const std::int32_t> labels) {
      LabelVolume truth = registry.imageIOFor(groundTruth).readLabels(groundTruth);
      truthSplits = splitTruthBySide(truth, labels, floor, groundTruth, model.empty() ? "atlas" : "model");
      truthMap = writeBeside(".truth-parts.nii.gz", truth);
    };
    if (splitParts) {
      // The atlas: whichever labels are in parts on both sides (none of them need be).
      std::vector<std::int32_t> values;
      for (const LabelEntry* e : chosen) values.push_back(e->value);
      LabelVolume labels = registry.imageIOFor(atlas).readLabels(atlas);
      splits = splitBySide(labels, values, floor);
      checkSideValues(splits, atlas);
      if (!splits.empty()) atlasMap = writeBeside(".atlas-parts.nii.gz", labels);
      std::vector<std::int32_t> split;  // only the labels split in the atlas
      for (const SideParts& p : splits) split.push_back(p.label);
      if (!groundTruth.empty() && !splits.empty()) {
        splitTruth(split);
      } else if (groundTruth.empty()) {  // demo mode: the atlas is the truth
        truthMap = atlasMap;
        truthSplits = splits;
      }
      if (splits.empty()) std::cerr << "--split-parts: no label of the scene is in parts on both sides; none split\n";
      for (const SideParts& p : splits)
        std::cerr << "label " << p.label << " is in parts on both sides: split into " << p.left << " (left, "
                  << p.leftVoxels << " voxels) and " << p.right << " (right, " << p.rightVoxels << ")\n";
    } else if (!leftOf.empty() && !groundTruth.empty()) {
      std::vector<std::int32_t> sided;
      for (const LabelEntry* e : chosen)
        if (leftOf.count(e->name) && std::find(sided.begin(), sided.end(), e->value) == sided.end()) sided.push_back(e->value);
      if (!sided.empty()) splitTruth(sided);
      for (const SideParts& p : truthSplits)
        std::cerr << "label " << p.label << " of the truth is in parts on both sides, as in the model: split into "
                  << p.left << " (left, " << p.leftVoxels << " voxels) and " << p.right << " (right, " << p.rightVoxels << ")\n";
    }
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
    if (subject)
      desc << "made by sinew-make-scene in subject mode (" << (model.empty() ? "atlas " + atlas : "model " + model)
           << ", initialised by " << (transform.empty() ? initialise : "transform " + transform) << ")";
    else
      desc << "made by sinew-make-scene --seed " << seed << " --max-rotation-deg " << maxRotation
           << " --max-translation-mm " << maxTranslation << " --scale-min " << scaleMin << " --scale-max " << scaleMax;
    scene["description"] = desc.str();
    scene["images"] = {{"target", absolute(target)}};
    if (!training.empty()) scene["images"]["training"] = absolute(training);
    Json items = Json::array();
    // Each structure, or each side of a label split in two (named NAME_L and NAME_R): its name, its
    // output value, its value in the reference map and in the truth's.
    struct Part {
      std::string name;
      std::int32_t label, reference, truth;
    };
    std::vector<Part> parts;
    const auto sideValue = [](std::span<const SideParts> in, std::int32_t label, bool left) -> std::optional<std::int32_t> {
      const auto s = std::find_if(in.begin(), in.end(), [&](const SideParts& p) { return p.label == label; });
      if (s == in.end()) return std::nullopt;
      return left ? s->left : s->right;
    };
    for (const LabelEntry* e : chosen) {
      if (const auto side = leftOf.find(e->name); side != leftOf.end()) {  // a model's side: its truth's side
        parts.push_back({e->name, e->value, e->value, sideValue(truthSplits, e->value, side->second).value_or(e->value)});
        continue;
      }
      const std::optional<std::int32_t> left = sideValue(splits, e->value, true);
      if (!left) {
        parts.push_back({e->name, e->value, e->value, e->value});
        continue;
      }
      for (const bool isLeft : {true, false})
        parts.push_back({e->name + (isLeft ? "_L" : "_R"), e->value, *sideValue(splits, e->value, isLeft),
                         sideValue(truthSplits, e->value, isLeft).value_or(e->value)});
    }
    for (const Part& p : parts) {
      Json s;
      s["name"] = p.name;
      s["label"] = p.label;
      if (model.empty()) s["reference"] = {{"label_map", atlasMap}, {"label", p.reference}};
      if (!subject) {
        const Eigen::Vector3d axis = direction(), shift = direction() * (maxTranslation * unit(rng));
        s["initial"] = {{"rotation_axis", {axis.x(), axis.y(), axis.z()}},
                        {"rotation_deg", maxRotation * unit(rng)},
                        {"translation_mm", {shift.x(), shift.y(), shift.z()}},
                        {"scale", scaleMin + (scaleMax - scaleMin) * unit(rng)}};
      }
      if (!subject || !groundTruth.empty())
        s["ground_truth"] = {{"label_map", truthMap}, {"label", p.truth}};
      items.push_back(s);
    }
    scene["structures"] = items;
    // Forces and schedule tuned on the Colin27 demo (docs/demo.md): a strong shape prior keeps each
    // structure's shape while gentle profile forces move it; a trace of smoothing keeps it regular.
    scene["forces"] = {
        {"smoothing", {{"weight", 0.02}}},
        {"shape_prior", {{"weight", 1.0}}},
        {"intensity_profile", {{"weight", 0.2}, {"inside_samples", 25}, {"outside_samples", 5}, {"spacing", 0.5}}}};
    // Collisions (docs/collisions.md): on for several structures, at the finest level only in subject
    // mode, where registration places the structures consistently and pushing the coarser meshes
    // apart cost accuracy; in demo mode, whose random placements overlap from the start, at every
    // level but the coarsest (at least two; measured both ways at 3 levels). Only the two finest
    // at 4-6 levels left the overlaps of the levels between uncorrected: at 6 levels 74 mm^3 on
    // average (demo seeds 1-15, CUDA) and 2 runs stopped, against 0.97 mm^3 and 1 (docs/collisions.md).
    const bool collisions = collisionWeight > 0.0 && items.size() >= 2;
    scene["integrator"] = {{"name", "damped_verlet"}, {"time_step", 0.5}, {"damping", 0.6}};
    const auto counts = splitList(iterations);
    if (counts.empty() || counts.size() > 6) throw sinew::InputError("--iterations: give 1 to 6 counts");
    if (collisionLevels == 0) collisionLevels = subject ? 1 : std::max(2, int(counts.size()) - 1);
    // A full search every 16 steps (contact planes between) cost nothing measurable in accuracy at 3
    // and 4 levels (18 new subjects, demo seeds 1-8 and 1-5) and takes a third of the collisions'
    // GPU time or less. At 5 levels and more it lost accuracy at the levels' first steps, where the
    // structures move the most: there the first 8 steps search in full as well (demo seeds 1-10,
    // as accurate as a search every step on CUDA; docs/collisions.md).
    if (collisionSearchEvery == 0) collisionSearchEvery = 16;
    if (collisions) {
      scene["forces"]["collision"] = {{"weight", 0.0}, {"margin_mm", collisionMargin}, {"full_search_every", collisionSearchEvery}};
      const bool fineSchedule = counts.size() >= 5;  // finest spacings of about 0.25 mm and less
      if (fineSchedule && collisionSearchEvery > 1) scene["forces"]["collision"]["full_search_first"] = 8;
      // From 5 levels the hold's jumps out of the overlaps the levels without collisions left fold
      // the fine surfaces: at 6 levels the shape guard stopped 8 of 15 demo runs, 1 with a hold of
      // at most 0.05 of a vertex's spacing a step; at 5 levels in subject mode one jump cost
      // Putamen_R 0.34 mm of ASSD, and over 14 subjects the limit took the collisions' cost from
      // 0.0044 to 0.0015 mm. At 3 levels it only left more overlap (docs/collisions.md).
      if (fineSchedule) scene["forces"]["collision"]["hold_step"] = 0.05;
      // The other side pushed back by what a vertex does not take of a contact (the share by size):
      // less overlap and ASSD than taking more of it oneself, on both backends and every structure
      // set (docs/collisions.md, "The reaction").
      scene["forces"]["collision"]["reaction"] = kCollisionReaction;
      scene["forces"]["collision"]["size_share"] = kCollisionSizeShare;
      if (!sharesFrom.empty()) {
        std::vector<std::string> names;
        for (const auto& s : items) names.push_back(s["name"].get<std::string>());
        const Json shares = collisionSharesFor(learnContactSides(registry, sharesFrom), names, sharesMinContacts);
        if (!shares.empty()) scene["collision_shares"] = shares;
        std::cerr << "collision shares by pair: " << shares.size() << " pair(s) learned from " << sharesFrom.size() << " run(s)\n";
      }
    } else if (!sharesFrom.empty()) {
      throw sinew::InputError("--collision-shares-from: the scene has no collisions (two or more structures and "
                              "--collision-weight above 0)");
    }
    if (contactWeight < 0.0) contactWeight = subject ? kSubjectContactWeight : 0.0;
    const bool contacts = contactWeight > 0.0 && items.size() >= 2 && counts.size() >= 2;
    if (contacts) {
      // Every pair: the force links only vertices within its distance of the partner, and pairs far
      // apart cost it a box test (core/src/contact_links.cpp).
      Json pairs = Json::array();
      for (size_t a = 0; a < items.size(); ++a)
        for (size_t b = a + 1; b < items.size(); ++b) pairs.push_back({items[a]["name"], items[b]["name"]});
      scene["contact_pairs"] = pairs;
      scene["forces"]["contacts"] = {{"weight", contactWeight}, {"distance_mm", 2.0}};
    }
    Json schedule = Json::array();
    for (size_t l = 0; l < counts.size(); ++l) {
      // The search depth decreases (paper 001). A registered model starts within a millimetre or two
      // of the boundary (docs/accuracy.md), so subject mode searches less far: a longer search finds
      // the wrong edge of a neighbour more often than it finds the right one.
      const double depth = subject ? 2.0 / std::pow(2.0, double(l)) : std::max(1.0, 4.0 / std::pow(2.0, double(l)));
      Json level = {{"iterations", std::stoi(counts[l])}, {"forces", {{"intensity_profile", {{"search_depth", depth}}}}}};
      // Subject mode: the image forces' closest affine field takes 100 % at the coarsest level, down
      // to 20 % at the finest (paper 001 section 3).
      if (subject)
        level["affine_regularisation"] = counts.size() == 1 ? 0.2 : 1.0 - 0.8 * double(l) / double(counts.size() - 1);
      // Subject mode: the coarser levels' shape forces carried to the finer ones at half weight
      // (paper 001 section 2.1; docs/accuracy.md has the sweep).
      if (subject && l > 0) level["coarse_forces"] = 0.5;
      if (collisions && l + collisionLevels >= counts.size()) level["forces"]["collision"] = {{"weight", collisionWeight}};
      if (contacts && l + 1 == counts.size())  // (rounded, so that the scene reads 0.1, not 0.09999999999999999)
        level["forces"]["contacts"] = {{"weight", std::round(contactWeight * kFinestContactShare * 1e6) / 1e6}};
      schedule.push_back(level);
    }
    scene["schedule"] = schedule;
    scene["model"] = {{"coarse_spacing_mm", coarseSpacing}};
    if (!model.empty()) scene["model"] = absolute(model);
    if (subject && !transform.empty()) scene["initialise"] = {{"transform", absolute(transform)}};
    else if (subject && initialise != "none") scene["initialise"] = {{"registration", initialise}};
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
    for (const auto& map : partMaps) map->commit();  // before the scene that names them
    file.commit();
    if (subject) std::cerr << "wrote " << output << " (" << items.size() << " structures, subject mode)\n";
    else std::cerr << "wrote " << output << " (" << items.size() << " structures, seed " << seed << ")\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "sinew-make-scene: error: " << e.what() << "\n";
    return 3;
  }
}

// sinew-build-model: builds a reusable model once (docs/model-format.md): the reference shape of
// every structure at every level of detail, from an atlas (label map + label list) or from closed
// meshes, with the atlas image it is trained on and the provenance of its inputs. Scenes name the
// model folder instead of rebuilding the shapes from labels in every run.
#include "builtin_plugins.h"
#include "label_list.h"
#include "label_parts.h"
#include "sinew/core/executor.h"
#include "sinew/core/model_builder.h"
#include "sinew/core/model_file.h"

#include <CLI/CLI.hpp>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>

namespace fs = std::filesystem;
using namespace sinew;

namespace {
std::string utcNow() {
  const std::time_t t = std::time(nullptr);
  char b[32];
  std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&t));
  return b;
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App cli{"sinew-build-model: build a reusable segmentation model from an atlas or from meshes."};
  std::string atlas, labelList, training, output, structures = kDefaultStructures;
  std::vector<std::string> meshes;
  int levels = 3, threads = 0;
  double coarseSpacing = 4.0;
  bool quiet = false, splitParts = false;
  cli.add_option("--atlas", atlas, "atlas label map (the reference shapes)");
  cli.add_option("--labels", labelList,
                 "label list of the atlas, 'value name' per line (without it, --structures are label values, named label_VALUE)");
  cli.add_option("--structures", structures, "comma-separated label names or values")->capture_default_str();
  cli.add_option("--mesh", meshes, "NAME=FILE[:LABEL]: a structure from a closed triangle mesh instead (repeatable)");
  cli.add_option("--training", training, "the atlas image: profiles are trained on it, registration uses it")->required();
  cli.add_option("--levels", levels, "levels of detail")->check(CLI::Range(1, 6))->capture_default_str();
  cli.add_option("--coarse-spacing-mm", coarseSpacing, "vertex spacing at the coarsest level")
      ->check(CLI::PositiveNumber)->capture_default_str();
  cli.add_option("-j,--threads", threads, "CPU threads (0 = all)")->check(CLI::NonNegativeNumber);
  cli.add_option("-o,--output", output, "model folder to write")->required();
  cli.add_flag("--split-parts", splitParts,
               "a label in parts apart from each other on both sides (a parcel of both hemispheres) becomes two "
               "structures, NAME_L and NAME_R, each built from its side; both keep the label's value in output label maps");
  cli.add_flag("-q,--quiet", quiet, "no progress output");
  cli.footer("Exit codes: 0 success, 2 bad command line, 3 bad input (the message names the file).");
  cli.set_version_flag("--version", std::string("sinew-build-model ") + SINEW_VERSION);
  try {
    cli.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return cli.exit(e) == 0 ? 0 : 2;
  }
  if (meshes.empty() == atlas.empty() || (atlas.empty() && (!labelList.empty() || splitParts))) {
    std::fprintf(stderr, "sinew-build-model: give either --atlas (with --labels to name its labels, --split-parts to split "
                         "labels by side), or one or more --mesh\n");
    return 2;
  }
  const auto start = std::chrono::steady_clock::now();
  auto log = [&](const std::string& m) {
    if (!quiet) std::fprintf(stderr, "%s\n", m.c_str());
  };
  try {
    Registry registry;
    PluginLoader plugins(registry);
    addBuiltinPlugins(plugins);
    Executor executor(threads);
    Model model;
    model.coarseSpacingMm = coarseSpacing;
    model.createdBy = std::string("sinew-build-model ") + SINEW_VERSION;
    model.created = utcNow();
    model.atlasImage = training;
    model.inputs.push_back(describeInput("atlas_image", training));
    registry.imageIOFor(training);  // a format Sinew reads, checked before the long work
    if (!atlas.empty()) {
      model.inputs.push_back(describeInput("labels", atlas));
      if (!labelList.empty()) model.inputs.push_back(describeInput("label_list", labelList));
      const auto list = labelList.empty() ? unnamedLabels(splitList(structures)) : readLabelList(labelList);
      log("reading " + atlas);
      LabelVolume labels = registry.imageIOFor(atlas).readLabels(atlas);
      std::vector<const LabelEntry*> entries;
      for (const std::string& key : splitList(structures)) entries.push_back(&findLabel(list, key, labelList));
      // The labels in parts on both sides, split in the map in memory: each side takes a value of its own.
      std::vector<SideParts> splits;
      if (splitParts) {
        std::vector<std::int32_t> values;
        for (const LabelEntry* e : entries) values.push_back(e->value);
        splits = splitBySide(labels, values);
        if (splits.empty()) std::fprintf(stderr, "sinew-build-model: --split-parts: no label is in parts on both sides; none split\n");
        for (const SideParts& p : splits)
          log("label " + std::to_string(p.label) + " is in parts on both sides: split into its left (" +
              std::to_string(p.leftVoxels) + " voxels) and right (" + std::to_string(p.rightVoxels) + ")");
      }
      const auto extents = labelExtents(labels);  // one pass, not one per structure and surface
      const auto build = [&](const std::string& name, int label, std::int32_t inMap, const std::string& side) {
        log("structure '" + name + "' (label " + std::to_string(label) + (side.empty() ? "" : ", its " + side + " side") +
            "): " + std::to_string(levels) + " levels");
        const auto extent = extents.find(inMap);
        BuiltModel b = buildModelFromLabel(registry, labels, atlas, inMap, name, coarseSpacing, levels, executor,
                                           extent == extents.end() ? nullptr : &extent->second);
        if (const std::string note = b.partNote(name, label, side); !note.empty())
          std::fprintf(stderr, "sinew-build-model: note: %s\n", note.c_str());
        model.structures.push_back({name, label, std::move(b.levels), std::move(b.positions), side});
      };
      for (const LabelEntry* e : entries) {
        const auto split = std::find_if(splits.begin(), splits.end(), [&](const SideParts& p) { return p.label == e->value; });
        if (split == splits.end()) {
          build(e->name, e->value, e->value, "");
        } else {
          build(e->name + "_L", e->value, split->left, "left");
          build(e->name + "_R", e->value, split->right, "right");
        }
      }
    } else {
      int nextLabel = 1;
      for (const std::string& spec : meshes) {
        const auto eq = spec.find('=');
        if (eq == std::string::npos || eq == 0) throw InputError("--mesh " + spec + ": expected NAME=FILE[:LABEL]");
        std::string file = spec.substr(eq + 1);
        int label = nextLabel;
        if (const auto colon = file.rfind(':'); colon != std::string::npos) {
          label = std::stoi(file.substr(colon + 1));
          file = file.substr(0, colon);
        }
        nextLabel = label + 1;
        model.inputs.push_back(describeInput("mesh", file));
        log("structure '" + spec.substr(0, eq) + "' from " + file);
        BuiltModel b = buildModelFromMesh(registry.meshIOFor(file).read(file), file, levels, executor);
        model.structures.push_back({spec.substr(0, eq), label, std::move(b.levels), std::move(b.positions)});
      }
    }
    writeModel(registry, model, output);
    const double seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::fprintf(stderr, "wrote the model %s: %zu structures, %d levels (%.2f s)\n", output.c_str(),
                 model.structures.size(), levels, seconds);
    return 0;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "sinew-build-model: error: %s\n", e.what());
    return 3;
  }
}

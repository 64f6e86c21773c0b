// The scene file: what to segment, with which forces, integrator and level-of-detail schedule,
// against which ground truth, and what to write. JSON, versioned, schema in
// resources/scene.schema.json; unknown keys and wrong types are errors naming the JSON path.
#pragma once

#include "sinew/core/spatial_map.h"
#include "sinew/core/stability.h"
#include "sinew/core/types.h"

#include <array>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace sinew {

inline constexpr int kSceneVersion = 1;

// force name -> parameter name -> value; kept in the order of the file.
using ForceSettings = std::vector<std::pair<std::string, std::vector<std::pair<std::string, double>>>>;

struct LabelRef {
  std::filesystem::path labelMap;
  int label = 0;
};

struct ShapeSource {
  std::optional<std::filesystem::path> mesh;  // a closed triangle mesh
  std::optional<LabelRef> label;              // or a label of a label map
};

struct Placement {
  std::optional<std::filesystem::path> mesh;     // a mesh of the reference's topology
  std::optional<std::array<double, 16>> matrix;  // row-major 4x4 world transform
  // Similarity about the reference's centroid: rotation by an angle about an axis, then scale,
  // then translation.
  std::array<double, 3> rotationAxis{0, 0, 1};
  double rotationDeg = 0.0;
  std::array<double, 3> translationMm{0, 0, 0};
  double scale = 1.0;
};

struct StructureDesc {
  std::string name;
  int label = 1;  // value in the exported label map
  ShapeSource reference;  // neither mesh nor label: the scene's model's structure of this name
  Placement initial;
  ForceSettings forces;
  double density = 0.0;
  // The least vertex mass as a share of the structure's mean (StructureSpec::massFloor). Off by
  // default: docs/stability.md has what 0.3 does, and why it is not the default yet.
  double massFloor = 0.0;
  std::optional<LabelRef> groundTruth;
  std::vector<std::array<double, 3>> attractionPointsMm;  // placed by the user (paper 000 section 4.5)
  // Points the structure must include or exclude (paper 001 section 4).
  std::vector<std::array<double, 3>> includePointsMm, excludePointsMm;
};

struct LevelDesc {
  int iterations = 0;
  ForceSettings forces;  // parameter changes applied to every structure on entering the level
  // Share of the image forces replaced by their closest affine field, per structure (paper 001
  // section 3: 100 % at the coarsest level down to 20 %); 0 turns the regularisation off.
  double affineRegularisation = 0.0;
  // Weight of the shape forces of every coarser level, evaluated there and carried to this level
  // (paper 001 section 2.1); 0 turns it off.
  double coarseForces = 0.0;
};

// The global initialisation before the first level: the model's structures are mapped into the
// target by one map (the reference shapes with them, so the shape prior keeps the mapped shape).
// "registration": "bspline" without "bspline_cells" (docs/scene-format.md).
constexpr int kDefaultBSplineCells = 5;
struct InitialiseDesc {
  enum class Method { None, Registration, Transform, Landmarks };
  Method method = Method::None;
  bool affine = true;           // registration: rigid then affine; false: rigid only
  int bsplineCells = 0;         // registration "bspline": after the affine, a cubic B-spline of this many cells per axis
  int levels = 2;               // registration pyramid levels
  int iterations = 100;         // registration iterations per level and stage
  int samples = 10000;          // registration: the metric's random voxels per level
  std::optional<std::filesystem::path> movingImage;  // default: the model's atlas, else the training image
  std::filesystem::path transform;                   // an ITK transform file, target -> model
  std::vector<LandmarkPair> landmarks;
  bool thinPlateSpline = true;  // landmarks: thin-plate spline, else an affine fit
};

struct SceneDesc {
  std::filesystem::path file;  // where it was read from; relative paths are relative to it
  int version = kSceneVersion;
  std::string description;
  std::filesystem::path targetImage;
  std::optional<std::filesystem::path> trainingImage;
  std::vector<StructureDesc> structures;
  std::vector<std::string> plugins;  // run-time plugins the scene needs, loaded before it runs
  // Deforming contacts (paper 001 section 2.2): structure pairs whose reference proximity the
  // force `contacts` keeps as springs.
  std::vector<std::array<std::string, 2>> contactPairs;
  // How much of each contact correction each side of a pair takes, in place of the collision
  // force's sharing by size for that pair (docs/collisions.md, "Shares by pair").
  struct CollisionShare {
    std::array<std::string, 2> pair;
    std::array<double, 2> shares{1.0, 1.0};  // pair[0]'s vertices against pair[1], and the reverse
  };
  std::vector<CollisionShare> collisionShares;
  // Attachments (paper 001 section 2.2; docs/attachments.md), by structure name.
  struct Attachment {
    std::string kind;  // "surface" ("to"), "merge", "fixed" ("fixed_within_mm")
    std::string structure, other;
    double distanceMm = 1.0;
    std::array<double, 3> centreMm{0, 0, 0};
    double radiusMm = 0.0;
  };
  std::vector<Attachment> attachments;
  ForceSettings forces;  // the scene's forces in evaluation order, with scene-wide values
  std::string integrator = "damped_verlet";
  std::vector<std::pair<std::string, double>> integratorParams;
  std::vector<LevelDesc> schedule;
  std::optional<std::filesystem::path> model;  // a model folder (sinew-build-model) instead of labels
  InitialiseDesc initialise;
  double coarseSpacingMm = 4.0;      // target vertex spacing of a reference built at level 0
  StabilityGuard stability;          // "stability": the guard's limits
  int sampleInterval = 10;           // iterations between report samples
  double surfaceSampleSpacingMm = 0.5;
  std::string meshFormat = ".vtp";
  bool writeMeshes = true;
  bool thickness = false;  // "outputs.thickness": each mesh's medial radius per point, and its summary
  std::string labelMapName = "segmentation.nii.gz";
};

// Reads and validates a scene; throws InputError "FILE: /json/path: problem".
SceneDesc readScene(const std::filesystem::path& file);
// Parses a scene from text (file is used for messages and relative paths).
SceneDesc parseScene(const std::string& text, const std::filesystem::path& file);
// The scene as JSON text (paths absolute), readable by parseScene.
std::string sceneToJson(const SceneDesc& scene);
// Writes the scene through a temporary file and a rename; throws InputError naming the file.
void writeScene(const SceneDesc& scene, const std::filesystem::path& file);

}  // namespace sinew

#include "sinew/core/scene.h"

#include <nlohmann/json.hpp>

#include "json_integer.h"
#include "sinew/core/io.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <fstream>
#include <set>
#include <sstream>

namespace sinew {

namespace {
using Json = nlohmann::ordered_json;
namespace fs = std::filesystem;

// A JSON value with its path, for error messages that say exactly where the problem is.
class Node {
public:
  Node(const Json& j, std::string path, const fs::path& file) : j_(j), path_(std::move(path)), file_(file) {}

  [[noreturn]] void fail(const std::string& problem) const {
    throw InputError(file_.string() + ": " + (path_.empty() ? "/" : path_) + ": " + problem);
  }
  const Json& json() const { return j_; }

  void expectObject(std::initializer_list<const char*> known) const {
    if (!j_.is_object()) fail("expected an object, got " + typeName());
    std::set<std::string> k(known.begin(), known.end());
    for (auto it = j_.begin(); it != j_.end(); ++it)
      if (!k.count(it.key())) {
        std::string list;
        for (const auto& n : k) list += (list.empty() ? "" : ", ") + n;
        Node(it.value(), path_ + "/" + it.key(), file_).fail("unknown key (known: " + list + ")");
      }
  }
  bool has(const char* key) const { return j_.contains(key); }
  Node at(const char* key) const {
    if (!j_.contains(key)) fail(std::string("missing required key '") + key + "'");
    return Node(j_.at(key), path_ + "/" + key, file_);
  }
  std::vector<Node> elements() const {
    if (!j_.is_array()) fail("expected an array, got " + typeName());
    std::vector<Node> out;
    for (size_t i = 0; i < j_.size(); ++i) out.emplace_back(j_[i], path_ + "/" + std::to_string(i), file_);
    return out;
  }
  std::vector<std::pair<std::string, Node>> members() const {
    if (!j_.is_object()) fail("expected an object, got " + typeName());
    std::vector<std::pair<std::string, Node>> out;
    for (auto it = j_.begin(); it != j_.end(); ++it) out.emplace_back(it.key(), Node(it.value(), path_ + "/" + it.key(), file_));
    return out;
  }
  double number() const {
    if (!j_.is_number()) fail("expected a number, got " + typeName());
    return j_.get<double>();
  }
  int integer() const {
    if (!j_.is_number_integer()) fail("expected an integer, got " + typeName());
    const std::optional<int> i = integerOf<int>(j_);
    if (!i) fail("the integer " + j_.dump() + " is out of range");
    return *i;
  }
  bool boolean() const {
    if (!j_.is_boolean()) fail("expected true or false, got " + typeName());
    return j_.get<bool>();
  }
  std::string string() const {
    if (!j_.is_string()) fail("expected a string, got " + typeName());
    return j_.get<std::string>();
  }
  fs::path path() const {
    const fs::path p = string();
    return p.is_absolute() ? p : file_.parent_path() / p;
  }
  template <size_t N>
  std::array<double, N> numbers() const {
    const auto e = elements();
    if (e.size() != N) fail("expected " + std::to_string(N) + " numbers, got " + std::to_string(e.size()));
    std::array<double, N> out{};
    for (size_t i = 0; i < N; ++i) out[i] = e[i].number();
    return out;
  }

private:
  std::string typeName() const {
    if (j_.is_number_integer()) return "an integer";
    if (j_.is_number()) return "a number";
    return std::string("a ") + j_.type_name();
  }
  const Json& j_;
  std::string path_;
  const fs::path& file_;
};

// Output names must stay inside the output directory.
bool plainFileName(const std::string& name) {
  if (name.empty() || name == "." || name == "..") return false;
  for (char c : name)
    if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '-' || c == '.')) return false;
  return true;
}

LabelRef readLabelRef(const Node& n) {
  n.expectObject({"label_map", "label"});
  return {n.at("label_map").path(), n.at("label").integer()};
}

// {"force": {"param": number, ...}, ...}; names are checked against the registry later, when the
// plugins are loaded, but the shape is checked here.
ForceSettings readForces(const Node& n) {
  ForceSettings out;
  for (const auto& [force, params] : n.members()) {
    std::vector<std::pair<std::string, double>> values;
    for (const auto& [name, value] : params.members()) values.emplace_back(name, value.number());
    out.emplace_back(force, std::move(values));
  }
  return out;
}

StructureDesc readStructureRest(const Node& n, StructureDesc& s);

StructureDesc readStructure(const Node& n) {
  n.expectObject({"name", "label", "reference", "initial", "forces", "density", "mass_floor", "ground_truth", "attraction_points_mm",
                  "include_points_mm", "exclude_points_mm"});
  StructureDesc s;
  s.name = n.at("name").string();
  if (!plainFileName(s.name)) n.at("name").fail("the name names an output file: use letters, digits, '_', '-', '.' only");
  s.label = n.at("label").integer();
  if (s.label < 1 || s.label > 32767) n.at("label").fail("label values run from 1 to 32767");
  if (!n.has("reference")) return readStructureRest(n, s);
  const Node ref = n.at("reference");
  ref.expectObject({"mesh", "label_map", "label"});
  if (ref.has("mesh") == ref.has("label_map")) ref.fail("give either 'mesh' or 'label_map' with 'label'");
  if (ref.has("mesh")) {
    s.reference.mesh = ref.at("mesh").path();
    if (ref.has("label")) ref.at("label").fail("'label' goes with 'label_map', not 'mesh'");
  } else {
    s.reference.label = LabelRef{ref.at("label_map").path(), ref.at("label").integer()};
  }
  return readStructureRest(n, s);
}

StructureDesc readStructureRest(const Node& n, StructureDesc& s) {
  if (n.has("initial")) {
    const Node init = n.at("initial");
    init.expectObject({"mesh", "matrix", "rotation_axis", "rotation_deg", "translation_mm", "scale"});
    const int kinds = int(init.has("mesh")) + int(init.has("matrix")) +
                      int(init.has("rotation_deg") || init.has("rotation_axis") || init.has("translation_mm") ||
                          init.has("scale"));
    if (kinds > 1) init.fail("give one of 'mesh', 'matrix', or rotation_axis/rotation_deg/translation_mm/scale");
    if (init.has("mesh")) s.initial.mesh = init.at("mesh").path();
    if (init.has("matrix")) s.initial.matrix = init.at("matrix").numbers<16>();
    if (init.has("rotation_deg")) s.initial.rotationDeg = init.at("rotation_deg").number();
    if (init.has("rotation_axis")) {
      s.initial.rotationAxis = init.at("rotation_axis").numbers<3>();
      const auto& a = s.initial.rotationAxis;
      if (a[0] * a[0] + a[1] * a[1] + a[2] * a[2] == 0.0) init.at("rotation_axis").fail("the axis is zero");
    }
    if (init.has("translation_mm")) s.initial.translationMm = init.at("translation_mm").numbers<3>();
    if (init.has("scale")) {
      s.initial.scale = init.at("scale").number();
      if (!(s.initial.scale > 0.0)) init.at("scale").fail("the scale must be positive");
    }
  }
  if (n.has("forces")) s.forces = readForces(n.at("forces"));
  if (n.has("density")) {
    s.density = n.at("density").number();
    if (s.density < 0.0) n.at("density").fail("the density must be >= 0 (0 = automatic)");
  }
  if (n.has("mass_floor")) {
    s.massFloor = n.at("mass_floor").number();
    if (!(s.massFloor >= 0.0 && s.massFloor <= 1.0))
      n.at("mass_floor").fail("the mass floor must be between 0 and 1 (a share of the mean vertex mass)");
  }
  if (n.has("ground_truth")) s.groundTruth = readLabelRef(n.at("ground_truth"));
  const auto readPoints = [&](const char* key, std::vector<std::array<double, 3>>& out) {
    if (!n.has(key)) return;
    for (const Node& p : n.at(key).elements()) {
      out.push_back(p.numbers<3>());
      for (double v : out.back())
        if (!std::isfinite(v)) p.fail("coordinates must be finite");
    }
  };
  readPoints("attraction_points_mm", s.attractionPointsMm);
  readPoints("include_points_mm", s.includePointsMm);
  readPoints("exclude_points_mm", s.excludePointsMm);
  return s;
}

InitialiseDesc readInitialise(const Node& n) {
  n.expectObject({"registration", "iterations", "levels", "samples", "bspline_cells", "moving_image", "transform", "landmarks",
                  "landmark_fit"});
  InitialiseDesc d;
  const int methods = int(n.has("registration")) + int(n.has("transform")) + int(n.has("landmarks"));
  if (methods != 1) n.fail("give exactly one of 'registration', 'transform' or 'landmarks'");
  if (n.has("registration")) {
    d.method = InitialiseDesc::Method::Registration;
    const std::string kind = n.at("registration").string();
    if (kind != "rigid" && kind != "affine" && kind != "bspline")
      n.at("registration").fail("expected \"rigid\", \"affine\" or \"bspline\"");
    d.affine = kind != "rigid";
    if (kind == "bspline") d.bsplineCells = kDefaultBSplineCells;
    if (n.has("bspline_cells")) {
      if (kind != "bspline") n.at("bspline_cells").fail("goes with \"registration\": \"bspline\"");
      d.bsplineCells = n.at("bspline_cells").integer();
      if (d.bsplineCells < 1 || d.bsplineCells > 16) n.at("bspline_cells").fail("must be in [1, 16]");
    }
    if (n.has("iterations")) d.iterations = n.at("iterations").integer();
    if (d.iterations < 1 || d.iterations > 10000) n.at("iterations").fail("must be in [1, 10000]");
    if (n.has("levels")) d.levels = n.at("levels").integer();
    if (d.levels < 1 || d.levels > 4) n.at("levels").fail("must be in [1, 4]");
    if (n.has("samples")) d.samples = n.at("samples").integer();
    if (d.samples < 1000 || d.samples > 100000000) n.at("samples").fail("must be in [1000, 100000000]");
    if (n.has("moving_image")) d.movingImage = n.at("moving_image").path();
  } else {
    for (const char* k : {"iterations", "levels", "samples", "bspline_cells", "moving_image"})
      if (n.has(k)) n.at(k).fail("goes with 'registration'");
  }
  if (n.has("transform")) {
    d.method = InitialiseDesc::Method::Transform;
    d.transform = n.at("transform").path();
  }
  if (n.has("landmarks")) {
    d.method = InitialiseDesc::Method::Landmarks;
    const Node list = n.at("landmarks");
    for (const Node& p : list.elements()) {
      p.expectObject({"model", "target"});
      d.landmarks.push_back({p.at("model").numbers<3>(), p.at("target").numbers<3>()});
    }
    try {
      checkLandmarks(d.landmarks, "landmark pairs");
    } catch (const InputError& e) {
      list.fail(e.what());
    }
    if (n.has("landmark_fit")) {
      const std::string fit = n.at("landmark_fit").string();
      if (fit != "tps" && fit != "affine") n.at("landmark_fit").fail("expected \"tps\" or \"affine\"");
      d.thinPlateSpline = fit == "tps";
    }
  } else if (n.has("landmark_fit")) {
    n.at("landmark_fit").fail("goes with 'landmarks'");
  }
  return d;
}
}  // namespace

SceneDesc parseScene(const std::string& text, const fs::path& file) {
  Json json;
  try {
    json = Json::parse(text);
  } catch (const Json::parse_error& e) {
    std::string what = e.what();
    const auto colon = what.find("parse error");
    throw InputError(file.string() + ": not valid JSON: " + (colon == std::string::npos ? what : what.substr(colon)));
  } catch (const Json::exception& e) {
    // Other parser errors (a number too large for a double: found by fuzz_scene).
    throw InputError(file.string() + ": not valid JSON: " + e.what());
  }
  const Node root(json, "", file);
  root.expectObject({"version", "description", "images", "structures", "forces", "integrator", "schedule",
                     "model", "initialise", "report", "outputs", "stability", "plugins", "contact_pairs",
                     "collision_shares", "attachments"});
  SceneDesc s;
  s.file = file;
  s.version = root.at("version").integer();
  if (s.version != kSceneVersion)
    root.at("version").fail("scene version " + std::to_string(s.version) + " is not supported (this Sinew reads version " +
                            std::to_string(kSceneVersion) + ")");
  if (root.has("description")) s.description = root.at("description").string();
  if (root.has("plugins"))
    for (const Node& n : root.at("plugins").elements()) {
      const std::string name = n.string();
      if (name.empty() || name.find_first_not_of("abcdefghijklmnopqrstuvwxyz0123456789_") != std::string::npos)
        n.fail("'" + name + "' is not a plugin name (lower-case letters, digits and _)");
      s.plugins.push_back(name);
    }

  const Node images = root.at("images");
  images.expectObject({"target", "training"});
  s.targetImage = images.at("target").path();
  if (images.has("training")) s.trainingImage = images.at("training").path();

  for (const Node& n : root.at("structures").elements()) s.structures.push_back(readStructure(n));
  if (s.structures.empty()) root.at("structures").fail("the scene has no structure");
  std::set<std::string> names;
  for (size_t i = 0; i < s.structures.size(); ++i)
    if (!names.insert(s.structures[i].name).second)
      root.at("structures").fail("structure name '" + s.structures[i].name + "' is used twice");

  s.forces = readForces(root.at("forces"));
  const auto listed = [&](const char* force) {
    return std::any_of(s.forces.begin(), s.forces.end(), [&](const auto& f) { return f.first == force; });
  };
  if (root.has("contact_pairs")) {
    if (!listed("contacts"))
      root.at("contact_pairs").fail("contact pairs need the force that keeps them: add \"contacts\": {} to the scene's /forces");
    std::set<std::pair<std::string, std::string>> seen;
    for (const Node& pair : root.at("contact_pairs").elements()) {
      const auto members = pair.elements();
      if (members.size() != 2) pair.fail("expected two structure names");
      std::array<std::string, 2> p{members[0].string(), members[1].string()};
      for (int k = 0; k < 2; ++k)
        if (!names.count(p[k])) members[k].fail("no structure is named '" + p[k] + "'");
      if (p[0] == p[1]) pair.fail("a structure cannot be in contact with itself");
      if (!seen.insert(std::minmax(p[0], p[1])).second) pair.fail("the pair is listed twice");
      s.contactPairs.push_back(p);
    }
  }
  if (root.has("collision_shares")) {
    if (!listed("collision"))
      root.at("collision_shares").fail("shares by pair need the collision force: add \"collision\": {} to the scene's /forces");
    std::set<std::pair<std::string, std::string>> seen;
    for (const Node& entry : root.at("collision_shares").elements()) {
      entry.expectObject({"pair", "shares"});
      const auto members = entry.at("pair").elements();
      if (members.size() != 2) entry.at("pair").fail("expected two structure names");
      SceneDesc::CollisionShare c{{members[0].string(), members[1].string()}, entry.at("shares").numbers<2>()};
      for (int k = 0; k < 2; ++k) {
        if (!names.count(c.pair[k])) members[k].fail("no structure is named '" + c.pair[k] + "'");
        if (!(c.shares[k] >= 0.0 && c.shares[k] <= 1.0))
          entry.at("shares").fail("a share is the part of a correction a side takes: expected numbers from 0 to 1");
      }
      if (c.pair[0] == c.pair[1]) entry.at("pair").fail("a structure cannot collide with itself");
      if (!seen.insert(std::minmax(c.pair[0], c.pair[1])).second) entry.at("pair").fail("the pair is listed twice");
      s.collisionShares.push_back(c);
    }
  }
  if (root.has("attachments"))
    for (const Node& a : root.at("attachments").elements()) {
      a.expectObject({"structure", "to", "merge", "fixed_within_mm", "distance_mm"});
      SceneDesc::Attachment d;
      d.structure = a.at("structure").string();
      if (!names.count(d.structure)) a.at("structure").fail("no structure is named '" + d.structure + "'");
      const int kinds = int(a.has("to")) + int(a.has("merge")) + int(a.has("fixed_within_mm"));
      if (kinds != 1) a.fail("expected exactly one of \"to\" (a surface), \"merge\" (a structure) or \"fixed_within_mm\"");
      if (a.has("fixed_within_mm")) {
        const Node f = a.at("fixed_within_mm");
        f.expectObject({"centre", "radius"});
        d.kind = "fixed";
        d.centreMm = f.at("centre").numbers<3>();
        for (double v : d.centreMm)
          if (!std::isfinite(v)) f.at("centre").fail("coordinates must be finite");
        d.radiusMm = f.at("radius").number();
        if (!(d.radiusMm > 0.0 && d.radiusMm <= 1000.0)) f.at("radius").fail("must be in (0, 1000] mm");
        if (a.has("distance_mm")) a.at("distance_mm").fail("a fixed region has no distance (its sphere says which vertices)");
      } else {
        const char* key = a.has("to") ? "to" : "merge";
        d.kind = a.has("to") ? "surface" : "merge";
        d.other = a.at(key).string();
        if (!names.count(d.other)) a.at(key).fail("no structure is named '" + d.other + "'");
        if (d.other == d.structure) a.at(key).fail("a structure cannot be attached to itself");
        d.distanceMm = d.kind == "surface" ? 1.0 : 0.5;
        if (a.has("distance_mm")) d.distanceMm = a.at("distance_mm").number();
        if (!(d.distanceMm > 0.0 && d.distanceMm <= 20.0)) a.at("distance_mm").fail("must be in (0, 20] mm");
      }
      if (d.kind == "surface")
        for (const SceneDesc::Attachment& e : s.attachments)
          if (e.kind == "surface" && e.structure == d.other && e.other == d.structure)
            a.fail("'" + d.other + "' is already attached to '" + d.structure + "': attaching both ways leaves the contact without forces");
      s.attachments.push_back(d);
    }
  for (size_t i = 0; i < s.structures.size(); ++i)
    for (const auto& [force, params] : s.structures[i].forces) {
      bool known = false;
      for (const auto& f : s.forces) known |= f.first == force;
      if (!known)
        Node(json["structures"][i]["forces"][force], "/structures/" + std::to_string(i) + "/forces/" + force, file)
            .fail("force '" + force + "' is not listed in the scene's /forces");
    }
  // Placed points do nothing without the force that applies them: say so rather than ignore them.
  bool userPointsForce = false;
  for (const auto& f : s.forces) userPointsForce |= f.first == "attraction_points";
  for (size_t i = 0; i < s.structures.size() && !userPointsForce; ++i)
    for (const char* key : {"attraction_points_mm", "include_points_mm", "exclude_points_mm"})
      if (root.at("structures").elements()[i].has(key))
        root.at("structures").elements()[i].at(key).fail(
            "placed points need the force that applies them: add \"attraction_points\": {} to the scene's /forces");

  if (root.has("integrator")) {
    const Node integ = root.at("integrator");
    for (const auto& [key, value] : integ.members()) {
      if (key == "name") s.integrator = value.string();
      else s.integratorParams.emplace_back(key, value.number());
    }
  }

  for (const Node& n : root.at("schedule").elements()) {
    n.expectObject({"iterations", "forces", "affine_regularisation", "coarse_forces"});
    LevelDesc l;
    l.iterations = n.at("iterations").integer();
    if (l.iterations < 0) n.at("iterations").fail("iterations must be >= 0");
    if (n.has("affine_regularisation")) l.affineRegularisation = n.at("affine_regularisation").number();
    if (!(l.affineRegularisation >= 0.0 && l.affineRegularisation <= 1.0))
      n.at("affine_regularisation").fail("must be in [0, 1] (the share of the image forces made affine)");
    if (n.has("coarse_forces")) l.coarseForces = n.at("coarse_forces").number();
    if (!(l.coarseForces >= 0.0 && l.coarseForces <= 1.0))
      n.at("coarse_forces").fail("must be in [0, 1] (the weight of the coarser levels' shape forces)");
    if (n.has("forces")) l.forces = readForces(n.at("forces"));
    s.schedule.push_back(std::move(l));
  }
  if (s.schedule.empty()) root.at("schedule").fail("the schedule needs at least one level");
  if (s.schedule.size() > 6) root.at("schedule").fail("at most 6 levels of detail are supported");

  if (root.has("model")) {
    const Node m = root.at("model");
    if (m.json().is_string()) {
      s.model = m.path();
    } else {
      m.expectObject({"coarse_spacing_mm", "path"});
      if (m.has("path")) s.model = m.at("path").path();
      if (m.has("coarse_spacing_mm")) s.coarseSpacingMm = m.at("coarse_spacing_mm").number();
      if (!(s.coarseSpacingMm > 0.0)) m.at("coarse_spacing_mm").fail("must be positive");
    }
  }
  for (size_t i = 0; i < s.structures.size(); ++i)
    if (!s.model && !s.structures[i].reference.mesh && !s.structures[i].reference.label)
      root.at("structures").elements()[i].fail("missing required key 'reference' (or name a \"model\" in the scene)");
  if (root.has("initialise")) s.initialise = readInitialise(root.at("initialise"));
  if (root.has("stability")) {
    const Node g = root.at("stability");
    g.expectObject({"guard", "max_step_mm", "max_retries", "min_volume_ratio", "max_volume_ratio", "max_drift_mm",
                    "max_outside_fraction", "outside_band_mm", "max_inverted_fraction", "max_collapsed_fraction",
                    "max_self_intersecting_fraction", "max_swinging_fraction"});
    if (g.has("guard")) s.stability.enabled = g.at("guard").boolean();
    if (g.has("max_step_mm")) s.stability.maxStepMm = g.at("max_step_mm").number();
    if (!(s.stability.maxStepMm > 0.0)) g.at("max_step_mm").fail("must be positive");
    if (g.has("max_retries")) s.stability.maxRetries = g.at("max_retries").integer();
    if (s.stability.maxRetries < 0 || s.stability.maxRetries > 30) g.at("max_retries").fail("must be in [0, 30]");
    ShapeLimits& shape = s.stability.shape;
    if (g.has("min_volume_ratio")) shape.minVolumeRatio = g.at("min_volume_ratio").number();
    if (g.has("max_volume_ratio")) shape.maxVolumeRatio = g.at("max_volume_ratio").number();
    if (!(shape.minVolumeRatio >= 0.0 && shape.minVolumeRatio < 1.0))
      g.at("min_volume_ratio").fail("must be in [0, 1) (the smallest volume kept, as a share of the start's)");
    if (!(shape.maxVolumeRatio > 1.0)) g.at("max_volume_ratio").fail("must be above 1");
    if (g.has("max_drift_mm")) shape.maxDriftMm = g.at("max_drift_mm").number();
    if (!(shape.maxDriftMm > 0.0)) g.at("max_drift_mm").fail("must be positive");
    if (g.has("outside_band_mm")) shape.outsideBandMm = g.at("outside_band_mm").number();
    if (!(shape.outsideBandMm >= 0.0 && shape.outsideBandMm <= 1000.0)) g.at("outside_band_mm").fail("must be in [0, 1000] mm");
    // Shares of a structure's vertices, cells or sampled triangles.
    const auto fraction = [&](const char* key, double& value) {
      if (g.has(key)) value = g.at(key).number();
      if (!(value >= 0.0 && value <= 1.0)) g.at(key).fail("must be in [0, 1]");
    };
    fraction("max_outside_fraction", shape.maxOutsideFraction);
    fraction("max_inverted_fraction", shape.maxInvertedFraction);
    fraction("max_collapsed_fraction", shape.maxCollapsedFraction);
    fraction("max_self_intersecting_fraction", shape.maxSelfIntersectingFraction);
    fraction("max_swinging_fraction", shape.maxSwingingFraction);
  }
  if (root.has("report")) {
    const Node r = root.at("report");
    r.expectObject({"sample_interval", "surface_sample_spacing_mm"});
    if (r.has("sample_interval")) s.sampleInterval = r.at("sample_interval").integer();
    if (s.sampleInterval < 1) r.at("sample_interval").fail("must be >= 1");
    if (r.has("surface_sample_spacing_mm")) s.surfaceSampleSpacingMm = r.at("surface_sample_spacing_mm").number();
    if (!(s.surfaceSampleSpacingMm > 0.0)) r.at("surface_sample_spacing_mm").fail("must be positive");
  }
  if (root.has("outputs")) {
    const Node o = root.at("outputs");
    o.expectObject({"mesh_format", "meshes", "label_map", "thickness"});
    if (o.has("mesh_format")) s.meshFormat = o.at("mesh_format").string();
    if (o.has("meshes")) s.writeMeshes = o.at("meshes").boolean();
    if (o.has("thickness")) s.thickness = o.at("thickness").boolean();
    if (o.has("label_map")) s.labelMapName = o.at("label_map").string();
    if (!plainFileName(s.labelMapName)) o.at("label_map").fail("expected a file name such as \"segmentation.nii.gz\"");
    if (s.meshFormat.empty() || s.meshFormat[0] != '.') o.at("mesh_format").fail("expected an extension such as \".vtp\"");
  }
  return s;
}

namespace {
Json forcesJson(const ForceSettings& forces) {
  Json out = Json::object();
  for (const auto& [force, values] : forces) {
    Json params = Json::object();
    for (const auto& [name, value] : values) params[name] = value;
    out[force] = params;
  }
  return out;
}
Json labelRefJson(const LabelRef& r) { return {{"label_map", fs::absolute(r.labelMap).string()}, {"label", r.label}}; }
}  // namespace

std::string sceneToJson(const SceneDesc& s) {
  Json j;
  j["version"] = s.version;
  if (!s.description.empty()) j["description"] = s.description;
  j["images"]["target"] = fs::absolute(s.targetImage).string();
  if (s.trainingImage) j["images"]["training"] = fs::absolute(*s.trainingImage).string();
  Json structures = Json::array();
  for (const StructureDesc& d : s.structures) {
    Json o;
    o["name"] = d.name;
    o["label"] = d.label;
    if (d.reference.mesh) o["reference"]["mesh"] = fs::absolute(*d.reference.mesh).string();
    else if (d.reference.label) o["reference"] = labelRefJson(*d.reference.label);
    const Placement& p = d.initial;
    if (p.mesh) o["initial"]["mesh"] = fs::absolute(*p.mesh).string();
    else if (p.matrix) o["initial"]["matrix"] = *p.matrix;
    else
      o["initial"] = {{"rotation_axis", p.rotationAxis}, {"rotation_deg", p.rotationDeg},
                      {"translation_mm", p.translationMm}, {"scale", p.scale}};
    if (!d.forces.empty()) o["forces"] = forcesJson(d.forces);
    if (d.density != 0.0) o["density"] = d.density;
    if (d.massFloor != 0.0) o["mass_floor"] = d.massFloor;
    if (d.groundTruth) o["ground_truth"] = labelRefJson(*d.groundTruth);
    if (!d.attractionPointsMm.empty()) o["attraction_points_mm"] = d.attractionPointsMm;
    if (!d.includePointsMm.empty()) o["include_points_mm"] = d.includePointsMm;
    if (!d.excludePointsMm.empty()) o["exclude_points_mm"] = d.excludePointsMm;
    structures.push_back(o);
  }
  j["structures"] = structures;
  if (!s.plugins.empty()) j["plugins"] = s.plugins;
  if (!s.contactPairs.empty()) j["contact_pairs"] = s.contactPairs;
  for (const SceneDesc::CollisionShare& c : s.collisionShares)
    j["collision_shares"].push_back({{"pair", c.pair}, {"shares", c.shares}});
  for (const SceneDesc::Attachment& a : s.attachments) {
    Json o = {{"structure", a.structure}};
    if (a.kind == "fixed") o["fixed_within_mm"] = {{"centre", a.centreMm}, {"radius", a.radiusMm}};
    else {
      o[a.kind == "surface" ? "to" : "merge"] = a.other;
      o["distance_mm"] = a.distanceMm;
    }
    j["attachments"].push_back(o);
  }
  j["forces"] = forcesJson(s.forces);
  j["integrator"]["name"] = s.integrator;
  for (const auto& [name, value] : s.integratorParams) j["integrator"][name] = value;
  Json schedule = Json::array();
  for (const LevelDesc& l : s.schedule) {
    Json o{{"iterations", l.iterations}};
    if (!l.forces.empty()) o["forces"] = forcesJson(l.forces);
    if (l.affineRegularisation > 0.0) o["affine_regularisation"] = l.affineRegularisation;
    if (l.coarseForces > 0.0) o["coarse_forces"] = l.coarseForces;
    schedule.push_back(o);
  }
  j["schedule"] = schedule;
  j["model"]["coarse_spacing_mm"] = s.coarseSpacingMm;
  if (s.model) j["model"]["path"] = fs::absolute(*s.model).string();
  const InitialiseDesc& init = s.initialise;
  switch (init.method) {
    case InitialiseDesc::Method::None: break;
    case InitialiseDesc::Method::Registration:
      j["initialise"] = {{"registration", init.bsplineCells > 0 ? "bspline" : init.affine ? "affine" : "rigid"},
                         {"levels", init.levels}, {"iterations", init.iterations}, {"samples", init.samples}};
      if (init.bsplineCells > 0) j["initialise"]["bspline_cells"] = init.bsplineCells;
      if (init.movingImage) j["initialise"]["moving_image"] = fs::absolute(*init.movingImage).string();
      break;
    case InitialiseDesc::Method::Transform:
      j["initialise"] = {{"transform", fs::absolute(init.transform).string()}};
      break;
    case InitialiseDesc::Method::Landmarks: {
      Json list = Json::array();
      for (const auto& p : init.landmarks) list.push_back({{"model", p.model}, {"target", p.target}});
      j["initialise"] = {{"landmarks", list}, {"landmark_fit", init.thinPlateSpline ? "tps" : "affine"}};
      break;
    }
  }
  j["stability"] = {{"guard", s.stability.enabled},
                    {"max_step_mm", s.stability.maxStepMm},
                    {"max_retries", s.stability.maxRetries},
                    {"min_volume_ratio", s.stability.shape.minVolumeRatio},
                    {"max_volume_ratio", s.stability.shape.maxVolumeRatio},
                    {"max_drift_mm", s.stability.shape.maxDriftMm},
                    {"max_outside_fraction", s.stability.shape.maxOutsideFraction},
                    {"outside_band_mm", s.stability.shape.outsideBandMm},
                    {"max_inverted_fraction", s.stability.shape.maxInvertedFraction},
                    {"max_collapsed_fraction", s.stability.shape.maxCollapsedFraction},
                    {"max_self_intersecting_fraction", s.stability.shape.maxSelfIntersectingFraction},
                    {"max_swinging_fraction", s.stability.shape.maxSwingingFraction}};
  j["report"] = {{"sample_interval", s.sampleInterval}, {"surface_sample_spacing_mm", s.surfaceSampleSpacingMm}};
  j["outputs"] = {{"mesh_format", s.meshFormat}, {"meshes", s.writeMeshes}, {"label_map", s.labelMapName}, {"thickness", s.thickness}};
  return j.dump(2) + "\n";
}

void writeScene(const SceneDesc& scene, const fs::path& file) {
  const std::string text = sceneToJson(scene);
  AtomicOutput out(file);
  {
    std::ofstream f(out.tempPath());
    f << text;
    if (!f.flush()) throw InputError(file.string() + ": cannot write the scene file");
  }
  out.commit();
}

SceneDesc readScene(const fs::path& file) {
  std::ifstream in(file);
  if (!in) throw InputError(file.string() + ": cannot open the scene file");
  std::stringstream text;
  text << in.rdbuf();
  return parseScene(text.str(), file);
}

}  // namespace sinew

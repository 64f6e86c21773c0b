#include "report_writer.h"

#include <nlohmann/json.hpp>

#include <algorithm>

#include <cmath>
#include <fstream>
#include <iomanip>

namespace sinew {

namespace {
using Json = nlohmann::ordered_json;

Json number(double v) { return std::isnan(v) ? Json(nullptr) : Json(v); }

void writeText(const std::filesystem::path& path, const std::string& text) {
  AtomicOutput out(path);
  {
    std::ofstream f(out.tempPath());
    f << text;
    f.close();  // a failed flush (full disk) shows only here
    if (!f) throw InputError(path.string() + ": cannot write the file");
  }
  out.commit();
}

std::string csvNumber(double v) {
  if (std::isnan(v)) return "";
  std::ostringstream s;
  s << std::setprecision(6) << v;
  return s.str();
}
}  // namespace

void writeReportJson(const std::filesystem::path& path, const RunReport& r, const SceneDesc& scene,
                     std::span<const PluginRecord> plugins) {
  Json j;
  j["scene"] = scene.file.string();
  j["plugins"] = Json::array();
  for (const PluginRecord& p : plugins)
    if (!p.file.empty())
      j["plugins"].push_back({{"name", p.name}, {"version", p.version}, {"kind", pluginKindName(p.kind)}, {"file", p.file.string()}});
  j["backend"] = r.backend;
  j["device"] = r.device;
  j["threads"] = r.threads;
  j["total_seconds"] = r.totalSeconds;
  j["simulation_seconds"] = r.simulationSeconds;
  j["level_start_seconds"] = r.levelStartSeconds;
  j["stage_seconds"] = Json::object();
  for (const auto& [name, seconds] : r.stageClock.stages()) j["stage_seconds"][name] = seconds;
  j["background_seconds"] = Json::object();
  for (const auto& [name, seconds] : r.backgroundSeconds) j["background_seconds"][name] = seconds;
  {
    const InitialisationResult& in = r.initialisation;
    Json init{{"method", in.method}, {"seconds", in.seconds}};
    Json stages = Json::array();
    for (const RegistrationStage& st : in.registration)
      stages.push_back({{"name", st.name}, {"mattes_mi", st.metric}, {"iterations", st.iterations}, {"seconds", st.seconds},
                        {"kept", st.kept}});
    if (!in.registration.empty()) init["registration"] = stages;
    if (in.hasAffine) {
      Json m = Json::array();
      for (int row = 0; row < 4; ++row)
        for (int c = 0; c < 4; ++c) m.push_back(in.transform.targetToModel(row, c));
      init["target_to_model"] = m;
      const BSplineWarp& w = in.transform.deformation;  // applied before target_to_model
      if (!w.empty()) init["bspline_control_points"] = {w.size[0], w.size[1], w.size[2]};
      init["transform_file"] = "subject-to-atlas.tfm";
    }
    j["initialisation"] = init;
  }
  Json stages = Json::array();
  for (const StageResult& st : r.stages) {
    Json per = Json::object();
    double sum = 0.0;
    int n = 0;
    for (size_t i = 0; i < st.assdMm.size() && i < r.structures.size(); ++i) {
      per[r.structures[i].name] = number(st.assdMm[i]);
      if (!std::isnan(st.assdMm[i])) sum += st.assdMm[i], ++n;
    }
    stages.push_back({{"name", st.name}, {"seconds", st.seconds}, {"mean_assd_mm", n ? Json(sum / n) : Json(nullptr)},
                      {"assd_mm", per}});
    if (const auto& l = st.level) {
      stages.back()["enter_seconds"] = l->enter;
      stages.back()["step_seconds"] = l->steps;
      stages.back()["check_seconds"] = l->checks;
      stages.back()["rollbacks"] = l->rollbacks;
    }
  }
  j["stages"] = stages;
  if (r.structures.size() > 1) {
    double before = 0.0, after = 0.0;
    Json pairs = Json::array();
    for (const OverlapResult& o : r.overlaps) {
      before += o.beforeMm3;
      after += o.afterMm3;
      pairs.push_back({{"a", r.structures[o.a].name}, {"b", r.structures[o.b].name}, {"before_mm3", o.beforeMm3},
                       {"after_mm3", o.afterMm3}});
    }
    j["overlaps"] = {{"grid_spacing_mm", kOverlapSpacingMm}, {"total_before_mm3", before}, {"total_after_mm3", after},
                     {"pairs", pairs}};
  }
  j["status"] = r.numericalFailure.empty() ? "completed" : r.shapeFailure ? "degraded" : "numerical_failure";
  if (!r.numericalFailure.empty()) j["numerical_failure"] = r.numericalFailure;
  Json events = Json::array();
  for (const StabilityEvent& e : r.stability)
    events.push_back({{"iteration", e.iteration}, {"level", e.level}, {"reason", e.reason}, {"time_step", e.timeStep},
                      {"recovered", e.recovered}});
  j["stability"] = {{"rollbacks", std::count_if(r.stability.begin(), r.stability.end(), [](const StabilityEvent& e) { return e.recovered; })},
                    {"events", events}};
  Json structures = Json::array();
  for (const StructureResult& s : r.structures) {
    structures.push_back({{"name", s.name},
                          {"label", s.label},
                          {"vertices", s.vertices},
                          {"assd_mm", {{"model", number(s.assdModelMm)}, {"initial", number(s.assdInitialMm)}, {"final", number(s.assdFinalMm)}}},
                          {"hd95_mm", number(s.hd95Mm)},
                          {"dice", number(s.dice)},
                          {"dice_initial", number(s.diceInitial)},
                          {"dice_model", number(s.diceModel)},
                          {"outside_image_share", s.outsideImageShare},
                          {"image_fit", number(s.imageFit)},
                          {"profile_match", number(s.profileMatch)},
                          {"self_agreement", number(s.selfAgreement)},
                          {"seconds", s.seconds}});
    if (const auto& r = s.medialRadius)
      structures.back()["medial_radius_mm"] = {{"mean", r->mean}, {"p5", r->p5}, {"median", r->median}, {"p95", r->p95}, {"max", r->max}};
  }
  j["structures"] = structures;
  Json timeline = Json::array();
  for (const TimelineSample& t : r.timeline) {
    timeline.push_back({{"seconds", t.seconds},
                        {"iteration", t.iteration},
                        {"level", t.level},
                        {"structure", r.structures.empty() ? Json(t.structure) : Json(r.structures[t.structure].name)},
                        {"assd_mm", number(t.assdMm)},
                        {"hd95_mm", number(t.hd95Mm)},
                        {"dice", number(t.dice)},
                        {"mean_displacement_mm", t.meanDisplacementMm},
                        {"mean_force", t.meanForce}});
  }
  j["timeline"] = timeline;
  writeText(path, j.dump(2) + "\n");
}

void writeReportCsv(const std::filesystem::path& path, const RunReport& r) {
  std::ostringstream s;
  s << "structure,label,vertices,assd_model_mm,assd_initial_mm,assd_final_mm,hd95_mm,dice_model,dice_initial,dice,"
       "seconds,image_fit\n";
  for (const StructureResult& x : r.structures)
    s << x.name << ',' << x.label << ',' << x.vertices << ',' << csvNumber(x.assdModelMm) << ','
      << csvNumber(x.assdInitialMm) << ',' << csvNumber(x.assdFinalMm) << ',' << csvNumber(x.hd95Mm) << ','
      << csvNumber(x.diceModel) << ',' << csvNumber(x.diceInitial) << ',' << csvNumber(x.dice) << ','
      << csvNumber(x.seconds) << ',' << csvNumber(x.imageFit) << '\n';
  writeText(path, s.str());
}

void writeTimelineCsv(const std::filesystem::path& path, const RunReport& r, const SceneDesc& scene) {
  std::ostringstream s;
  s << "seconds,iteration,level,structure,assd_mm,hd95_mm,dice,mean_displacement_mm,mean_force\n";
  for (const TimelineSample& t : r.timeline)
    s << csvNumber(t.seconds) << ',' << t.iteration << ',' << t.level << ',' << scene.structures[t.structure].name
      << ',' << csvNumber(t.assdMm) << ',' << csvNumber(t.hd95Mm) << ',' << csvNumber(t.dice) << ',' << csvNumber(t.meanDisplacementMm)
      << ',' << csvNumber(t.meanForce)
      << '\n';
  writeText(path, s.str());
}

}  // namespace sinew

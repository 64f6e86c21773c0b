#include "cohort_report.h"

#include "sinew/core/types.h"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <cstdio>
#include <numeric>
#include <sstream>

namespace sinew::cohort {

namespace fs = std::filesystem;

namespace {

const double kNaN = std::nan("");

double number(const Json& j, const char* key) {
  return j.contains(key) && j[key].is_number() ? j[key].get<double>() : kNaN;
}

std::string csvField(const std::string& s) {
  if (s.find_first_of(",\"\n") == std::string::npos) return s;
  std::string out = "\"";
  for (char c : s) out += c == '"' ? std::string("\"\"") : std::string(1, c == '\n' ? ' ' : c);
  return out + "\"";
}

std::string num(double v) {
  if (std::isnan(v)) return "";
  char s[32];
  std::snprintf(s, sizeof s, "%.10g", v);
  return s;
}

double mean(const std::vector<double>& v) {
  double sum = 0;
  int n = 0;
  for (double x : v)
    if (!std::isnan(x)) sum += x, ++n;
  return n ? sum / n : kNaN;
}

struct Metric {
  const char* name;
  double StructureResult::*field;
};
constexpr Metric kMetrics[] = {{"assd_final_mm", &StructureResult::assdFinal},
                               {"assd_initial_mm", &StructureResult::assdInitial},
                               {"hd95_mm", &StructureResult::hd95},
                               {"dice", &StructureResult::dice}};

// The Mattes MI of a report's last linear registration stage (affine, else rigid): the B-spline's
// can make up for a wrong pose, theirs cannot. NaN without a registration.
double linearRegistrationMetric(const Json& report) {
  double metric = kNaN;
  if (!report.contains("initialisation") || !report["initialisation"].is_object()) return metric;
  for (const Json& stage : report["initialisation"].value("registration", Json::array())) {
    if (!stage.is_object()) continue;
    const std::string name = stage.value("name", std::string());
    if (name == "affine" || (name == "rigid" && std::isnan(metric))) metric = number(stage, "mattes_mi");
  }
  return metric;
}

Json statsJson(const Statistics& s) {
  return {{"n", s.n}, {"mean", s.mean}, {"sd", s.sd}, {"min", s.min}, {"q1", s.q1}, {"median", s.median}, {"q3", s.q3}, {"max", s.max}};
}

}  // namespace

Statistics statistics(std::vector<double> values) {
  values.erase(std::remove_if(values.begin(), values.end(), [](double v) { return std::isnan(v); }), values.end());
  Statistics s;
  s.n = int(values.size());
  if (values.empty()) {
    s.mean = s.sd = s.min = s.q1 = s.median = s.q3 = s.max = kNaN;
    return s;
  }
  std::sort(values.begin(), values.end());
  s.mean = std::accumulate(values.begin(), values.end(), 0.0) / s.n;
  double ss = 0;
  for (double v : values) ss += (v - s.mean) * (v - s.mean);
  s.sd = s.n > 1 ? std::sqrt(ss / (s.n - 1)) : 0.0;
  auto quantile = [&](double q) {
    const double pos = q * (s.n - 1);
    const size_t lo = size_t(std::floor(pos)), hi = std::min(lo + 1, values.size() - 1);
    return values[lo] + (pos - double(lo)) * (values[hi] - values[lo]);
  };
  s.min = values.front();
  s.max = values.back();
  s.q1 = quantile(0.25);
  s.median = quantile(0.5);
  s.q3 = quantile(0.75);
  return s;
}

std::vector<double> CohortReport::metric(const std::string& structure, double StructureResult::*field) const {
  std::vector<double> v;
  for (const StructureResult& r : results)
    if (r.structure == structure) v.push_back(r.*field);
  return v;
}

CohortReport gatherReport(const Cohort& cohort) {
  CohortReport rep;
  for (size_t i = 0; i < cohort.subjects.size(); ++i) {
    SubjectRow row;
    row.id = cohort.subjects[i].id;
    row.status = readStatus(cohort, i);
    row.totalSeconds = row.simulationSeconds = row.meanAssd = row.meanDice = row.overlapMm3 = kNaN;
    row.registrationMetric = row.outsideImageShare = row.lowestImageFit = kNaN;
    const std::string& st = row.status.status;
    const bool hasOutputs = (st == "completed" || st == "degraded") && fs::exists(cohort.outputDir(i) / "report.json");
    if (hasOutputs) {
      std::ifstream in(cohort.outputDir(i) / "report.json");
      const Json j = Json::parse(in, nullptr, false);
      if (j.is_discarded() || !j.is_object()) {
        row.status.status = "failed";
        row.status.message = (cohort.outputDir(i) / "report.json").string() + ": unreadable";
      } else {
        row.totalSeconds = number(j, "total_seconds");
        row.simulationSeconds = number(j, "simulation_seconds");
        if (j.contains("overlaps")) row.overlapMm3 = number(j["overlaps"], "total_after_mm3");
        row.registrationMetric = linearRegistrationMetric(j);
        std::vector<double> assd, dice;
        for (const Json& s : j.value("structures", Json::array())) {
          StructureResult r;
          r.subject = row.id;
          r.structure = s.value("name", std::string());
          r.label = s.value("label", 0);
          r.vertices = s.value("vertices", 0);
          const Json a = s.value("assd_mm", Json::object());
          r.assdInitial = number(a, "initial");
          r.assdFinal = number(a, "final");
          r.hd95 = number(s, "hd95_mm");
          r.dice = number(s, "dice");
          r.diceInitial = number(s, "dice_initial");
          const double outside = number(s, "outside_image_share");
          if (!std::isnan(outside) && (std::isnan(row.outsideImageShare) || outside > row.outsideImageShare))
            row.outsideImageShare = outside;
          const double fit = number(s, "image_fit");
          if (!std::isnan(fit) && (std::isnan(row.lowestImageFit) || fit < row.lowestImageFit))
            row.lowestImageFit = fit, row.lowestImageFitStructure = r.structure;
          assd.push_back(r.assdFinal);
          dice.push_back(r.dice);
          if (std::find(rep.structures.begin(), rep.structures.end(), r.structure) == rep.structures.end())
            rep.structures.push_back(r.structure);
          rep.results.push_back(r);
        }
        row.meanAssd = mean(assd);
        row.meanDice = mean(dice);
      }
    } else if (st == "completed" || st == "degraded") {
      row.status.status = "pending";  // its outputs are gone: it runs again
    }
    const std::string& now = row.status.status;
    (now == "completed" ? rep.completed : now == "degraded" ? rep.degraded : now == "pending" ? rep.pending : rep.failed)++;
    rep.subjects.push_back(std::move(row));
  }
  setRegistrationLimit(rep);
  // The learned shares, where the cohort's scenes were made from the template that holds them.
  std::ifstream prepared(cohort.dir / "cohort.json");
  const Json c = Json::parse(prepared, nullptr, false);
  std::ifstream learned(cohort.dir / "learning" / "shares.json");
  const Json l = Json::parse(learned, nullptr, false);
  if (c.is_object() && c.value("template", std::string()) == (cohort.dir / "template-shares.json").string() && l.is_object())
    try {
      rep.sharesLearnedFrom = l.at("from").get<std::vector<std::string>>();
      rep.sharesLearnedPairs = int(l.at("collision_shares").size());
    } catch (const Json::exception&) {
      rep.sharesLearnedFrom.clear();  // a damaged record: the report says nothing of it
    }
  return rep;
}

void setRegistrationLimit(CohortReport& rep) {
  std::vector<double> values;
  for (const SubjectRow& r : rep.subjects)
    if (!std::isnan(r.registrationMetric)) values.push_back(r.registrationMetric);
  rep.registrationMedian = rep.registrationLimit = kNaN;
  if (int(values.size()) < kRegistrationQuorum) return;
  rep.registrationMedian = statistics(values).median;
  for (double& v : values) v = std::abs(v - rep.registrationMedian);
  const double spread = 1.4826 * statistics(values).median;
  rep.registrationLimit = rep.registrationMedian + std::max(kRegistrationMargin, kRegistrationSpreads * spread);
}

void writeReport(const Cohort& cohort, const CohortReport& rep) {
  const fs::path dir = cohort.reportDir();
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(dir.string() + ": cannot create: " + ec.message());

  std::ostringstream subjects;
  subjects << "subject,status,exit_code,attempts,wall_seconds,total_seconds,simulation_seconds,backend,host,gpu,"
              "mean_assd_mm,mean_dice,overlap_mm3,registration_mattes_mi,registration_outlier,outside_image_share,"
              "lowest_image_fit,lowest_image_fit_structure,message\n";
  for (const SubjectRow& r : rep.subjects)
    subjects << csvField(r.id) << ',' << r.status.status << ',' << (r.status.exitCode >= 0 ? std::to_string(r.status.exitCode) : "")
             << ',' << r.status.attempts << ',' << num(r.status.seconds) << ',' << num(r.totalSeconds) << ','
             << num(r.simulationSeconds) << ',' << csvField(r.status.backend) << ',' << csvField(r.status.host) << ','
             << csvField(r.status.gpu) << ',' << num(r.meanAssd) << ',' << num(r.meanDice) << ',' << num(r.overlapMm3)
             << ',' << num(r.registrationMetric) << ',' << (rep.registrationStandsOut(r) ? "yes" : "") << ','
             << num(r.outsideImageShare) << ',' << num(r.lowestImageFit) << ',' << csvField(r.lowestImageFitStructure) << ','
             << csvField(r.status.message) << '\n';
  writeFileAtomically(dir / "subjects.csv", subjects.str());

  std::ostringstream structures;
  structures << "subject,structure,label,vertices,assd_initial_mm,assd_final_mm,hd95_mm,dice_initial,dice\n";
  for (const StructureResult& r : rep.results)
    structures << csvField(r.subject) << ',' << csvField(r.structure) << ',' << r.label << ',' << r.vertices << ','
               << num(r.assdInitial) << ',' << num(r.assdFinal) << ',' << num(r.hd95) << ',' << num(r.diceInitial) << ','
               << num(r.dice) << '\n';
  writeFileAtomically(dir / "structures.csv", structures.str());

  std::ostringstream summary;
  summary << "structure,metric,n,mean,sd,min,q1,median,q3,max\n";
  Json perStructure = Json::object();
  for (const std::string& name : rep.structures) {
    Json metrics = Json::object();
    for (const Metric& m : kMetrics) {
      const Statistics s = statistics(rep.metric(name, m.field));
      summary << csvField(name) << ',' << m.name << ',' << s.n << ',' << num(s.mean) << ',' << num(s.sd) << ',' << num(s.min)
              << ',' << num(s.q1) << ',' << num(s.median) << ',' << num(s.q3) << ',' << num(s.max) << '\n';
      if (s.n) metrics[m.name] = statsJson(s);
    }
    perStructure[name] = metrics;
  }
  writeFileAtomically(dir / "summary.csv", summary.str());

  Json failures = Json::array();
  std::vector<double> wall;
  for (const SubjectRow& r : rep.subjects) {
    if (r.status.status != "completed" && r.status.status != "pending")
      failures.push_back({{"subject", r.id}, {"status", r.status.status}, {"exit_code", r.status.exitCode},
                          {"attempts", r.status.attempts}, {"message", r.status.message}});
    if (r.status.attempts) wall.push_back(r.status.seconds);
  }
  Json outliers = Json::array();
  for (const SubjectRow& r : rep.subjects)
    if (rep.registrationStandsOut(r)) outliers.push_back({{"subject", r.id}, {"mattes_mi", r.registrationMetric}});
  const auto orNull = [](double v) { return std::isnan(v) ? Json(nullptr) : Json(v); };
  Json poorFits = Json::array();
  for (const SubjectRow& r : rep.subjects)
    if (r.lowestImageFit < kPoorImageFit)
      poorFits.push_back({{"subject", r.id}, {"structure", r.lowestImageFitStructure}, {"image_fit", r.lowestImageFit}});
  Json pending = Json::array();
  for (const SubjectRow& r : rep.subjects)
    if (r.status.status == "pending") pending.push_back(r.id);
  const Json j = {{"cohort", cohort.dir.string()},
                  {"subjects", rep.subjects.size()},
                  {"completed", rep.completed},
                  {"degraded", rep.degraded},
                  {"failed", rep.failed},
                  {"pending", pending},
                  {"failures", failures},
                  {"registration", {{"median_mattes_mi", orNull(rep.registrationMedian)},
                                    {"outlier_above", orNull(rep.registrationLimit)},
                                    {"outliers", outliers}}},
                  {"poor_image_fit", {{"below", kPoorImageFit}, {"subjects", poorFits}}},
                  {"subject_wall_seconds", statsJson(statistics(wall))},
                  {"collision_shares_learned", rep.sharesLearnedFrom.empty()
                                                   ? Json(nullptr)
                                                   : Json{{"from", rep.sharesLearnedFrom}, {"pairs", rep.sharesLearnedPairs}}},
                  {"structures", perStructure}};
  writeBoxPlot(dir / "assd_boxplot.png", rep, &StructureResult::assdFinal, "Final ASSD per structure", "ASSD (mm)");
  writeBoxPlot(dir / "dice_boxplot.png", rep, &StructureResult::dice, "Dice per structure", "Dice");
  writeRunTimePlot(dir / "run_time.png", rep);
  // Last: its presence says the report is whole.
  writeFileAtomically(dir / "cohort_report.json", j.dump(2) + "\n");
}

}  // namespace sinew::cohort

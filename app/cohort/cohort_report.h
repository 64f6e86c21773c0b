// The cohort report: every subject's report.json and status gathered into CSV files, statistics per
// structure, a JSON summary and plots (docs/cohorts.md).
#pragma once

#include "cohort.h"
#include "sinew/core/image_fit.h"

#include <map>
#include <string>
#include <vector>

namespace sinew::cohort {

struct StructureResult {
  std::string subject, structure;
  int label = 0, vertices = 0;
  double assdInitial = 0, assdFinal = 0, hd95 = 0, dice = 0, diceInitial = 0;  // NaN without ground truth
};

struct SubjectRow {
  std::string id;
  SubjectStatus status;
  double totalSeconds = 0, simulationSeconds = 0;  // sinew-run's own (NaN when it wrote no report)
  double meanAssd = 0, meanDice = 0, overlapMm3 = 0;
  // The registration's last linear stage's Mattes MI (the affine's, else the rigid's; NaN without a
  // registration: a transform or landmarks given), and the largest share of a structure's vertices
  // past the target's field of view at the end.
  double registrationMetric = 0, outsideImageShare = 0;
  // The lowest image fit of its structures (report.json's image_fit; NaN where none was reported)
  // and that structure's name: below kPoorImageFit the summary says to check the subject.
  double lowestImageFit = 0;
  std::string lowestImageFitStructure;
};

// Order statistics of one metric over subjects (quartiles by linear interpolation).
struct Statistics {
  int n = 0;
  double mean = 0, sd = 0, min = 0, q1 = 0, median = 0, q3 = 0, max = 0;
};
Statistics statistics(std::vector<double> values);  // NaNs are left out

struct CohortReport {
  std::vector<SubjectRow> subjects;
  std::vector<StructureResult> results;        // the subjects with outputs (completed or degraded)
  std::vector<std::string> structures;         // in the order first met
  int completed = 0, degraded = 0, failed = 0, pending = 0;
  // Where the cohort was prepared from learned collision shares (--learn-collision-shares): the
  // subjects they came from and how many pairs they share; empty otherwise.
  std::vector<std::string> sharesLearnedFrom;
  int sharesLearnedPairs = 0;
  // The subjects' registration metrics against the cohort's: their median, and the level above which a
  // subject's stands out (NaN with fewer than kRegistrationQuorum subjects registered).
  double registrationMedian = 0, registrationLimit = 0;
  // False where either is NaN (no registration, or too few registered subjects to judge).
  bool registrationStandsOut(const SubjectRow& row) const { return row.registrationMetric > registrationLimit; }
  std::vector<double> metric(const std::string& structure, double StructureResult::*field) const;
};

CohortReport gatherReport(const Cohort& cohort);

// A subject's registration stands out when its Mattes MI lies above the cohort's median by more than
// kRegistrationSpreads robust standard deviations (1.4826 times the median absolute deviation) and
// by at least kRegistrationMargin; judged among at least kRegistrationQuorum registered subjects.
// The metric's level differs with scanners and contrasts, so each cohort is its own reference.
constexpr int kRegistrationQuorum = 5;
constexpr double kRegistrationSpreads = 5.0, kRegistrationMargin = 0.1;
// Sets the report's registrationMedian and registrationLimit from its subjects (gatherReport does).
void setRegistrationLimit(CohortReport& report);

// Writes report/subjects.csv, structures.csv, summary.csv, cohort_report.json and the plots
// (assd_boxplot.png, dice_boxplot.png, run_time.png).
void writeReport(const Cohort& cohort, const CohortReport& report);

// The plots (cohort_plots.cpp; QtGui, offscreen).
void writeBoxPlot(const std::filesystem::path& path, const CohortReport& report, double StructureResult::*field,
                  const std::string& title, const std::string& axis);
void writeRunTimePlot(const std::filesystem::path& path, const CohortReport& report);

}  // namespace sinew::cohort

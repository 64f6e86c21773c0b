// sinew-cohort run / slurm --learn-collision-shares N: the collision's shares by pair learned from the
// cohort's own labelled subjects (docs/cohorts.md, "Shares learned from the cohort"). The first N
// subjects of the manifest with a ground truth run once more without collisions, in
// DIR/learning/ (a cohort of its own, resumed like any); the side of each pair that reached into
// the other's truth gives way (collision_share_learning.h); every subject's scene gets the shares.
// On Slurm the learning runs are an array of their own, and a job after it runs the same
// sinew-cohort slurm command again to learn and submit the cohort (sinew_cohort.cpp).
#pragma once

#include "cohort_run.h"

#include <filesystem>
#include <optional>

namespace sinew::cohort {

struct ShareLearning {
  int subjects = 0;       // labelled subjects to learn from (0: none)
  int minContacts = 100;  // contact points each side of a pair needs (sinew-make-scene's option)
};

// The learning cohort, DIR/learning: the manifest's first `learning.subjects` subjects with a
// ground truth, the template (every path absolute) with collisions off. Throws InputError naming
// the file: a template without collisions, a manifest without a subject with a ground truth.
Cohort prepareLearning(const std::filesystem::path& manifest, const std::filesystem::path& sceneTemplate,
                       const std::optional<std::filesystem::path>& model, const std::filesystem::path& dir,
                       const ShareLearning& learning);

// Whether every learning subject is done (completed, or degraded: sinew-run ended by itself).
bool learningDone(const Cohort& learners);

// Learns from the learning runs that completed and writes DIR/learning/shares.json (the shares,
// the subjects they came from) and DIR/template-shares.json (the template, every path absolute,
// with the shares): returns the latter. Throws InputError when no learning run completed.
std::filesystem::path learnFromRuns(const Cohort& learners, const std::filesystem::path& sceneTemplate,
                                    const std::filesystem::path& dir, const ShareLearning& learning, bool quiet);

// sinew-cohort run: prepareLearning, the learning subjects not done yet on the slots `local`
// describes, then learnFromRuns.
std::filesystem::path learnCollisionShares(const std::filesystem::path& manifest, const std::filesystem::path& sceneTemplate,
                                           const std::optional<std::filesystem::path>& model,
                                           const std::filesystem::path& dir, const ShareLearning& learning,
                                           const LocalOptions& local);

}  // namespace sinew::cohort

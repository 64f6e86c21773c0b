// sinew-cohort run --learn-collision-shares N: the collision's shares by pair learned from the
// cohort's own labelled subjects (docs/cohorts.md, "Shares learned from the cohort"). The first N
// subjects of the manifest with a ground truth run once more without collisions, in
// DIR/learning/ (a cohort of its own, resumed like any); the side of each pair that reached into
// the other's truth gives way (collision_share_learning.h); every subject's scene gets the shares.
#pragma once

#include "cohort_run.h"

#include <filesystem>
#include <optional>

namespace sinew::cohort {

struct ShareLearning {
  int subjects = 0;       // labelled subjects to learn from (0: none)
  int minContacts = 100;  // contact points each side of a pair needs (sinew-make-scene's option)
};

// Runs the learning subjects (those not done yet) on the slots `local` describes, learns, and
// returns the template to prepare the cohort from: DIR/template-shares.json, the given template
// with every path absolute and the learned `collision_shares` (DIR/learning/shares.json says which
// subjects they came from). Throws InputError naming the file: a template without collisions, a
// manifest without a subject with a ground truth, no learning run completed.
std::filesystem::path learnCollisionShares(const std::filesystem::path& manifest, const std::filesystem::path& sceneTemplate,
                                           const std::optional<std::filesystem::path>& model,
                                           const std::filesystem::path& dir, const ShareLearning& learning,
                                           const LocalOptions& local);

}  // namespace sinew::cohort

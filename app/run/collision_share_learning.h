// sinew-make-scene --collision-shares-from: the collision's shares by pair learned from labelled
// runs without collisions (docs/collisions.md, "Shares by pair, learned").
#pragma once

#include "sinew/core/contact_sides.h"
#include "sinew/core/registry.h"

#include <nlohmann/json.hpp>

#include <string>
#include <vector>

namespace sinew {

// Each run folder's meshes against its scene's ground truths (from its report.json), summed over
// the runs by structure name. Throws InputError naming the file: no report, a scene whose collision
// force has a weight above 0 anywhere, a structure without a ground truth or without its mesh.
struct ContactSidesByName {
  std::vector<std::string> names;
  std::vector<ContactSide> counts;  // names x names
};
ContactSidesByName learnContactSides(const Registry& registry, const std::vector<std::string>& runDirs);

// The scene's `collision_shares` for the pairs of `structures` that the runs saw touch.
nlohmann::json collisionSharesFor(const ContactSidesByName& learned, const std::vector<std::string>& structures,
                                  Index minContacts);

}  // namespace sinew

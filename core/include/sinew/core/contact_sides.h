// Which side of a pair of touching structures reaches into the other's truth, from labelled
// segmentations without collisions; and the collision's shares by pair that follow from it
// (docs/collisions.md, "Shares by pair, learned"). Where one structure's surface lies in the other's
// truth and the other's in its own, a contact should move the first: its share is the larger.
#pragma once

#include "sinew/core/io.h"
#include "sinew/core/types.h"

#include <span>
#include <vector>

namespace sinew {

struct ContactSide {
  Index contact = 0;       // a structure's surface points within reach of another's
  Index inOtherTruth = 0;  // of those, the ones inside the other structure's truth
};

// counts[a * n + b] for n structures: structure a's points within `reachMm` of one of b's, and how
// many of them lie in b's truth (label `labels[b]` of `truths[b]`, at the nearest voxel). A
// structure without a truth (nullptr) is left out on both sides.
std::vector<ContactSide> countContactSides(std::span<const std::vector<Vec3>> points,
                                           std::span<const LabelVolume* const> truths, std::span<const int> labels,
                                           float reachMm = 1.0f);

struct PairShares {
  Index a = -1, b = -1;
  double aShare = 1.0, bShare = 1.0;  // as the scene's collision_shares take them
};

// For each pair with at least `minContacts` contact points on each side: o = the share of a side's
// contact points in the other's truth (at least 0.05), and a side takes min(1, 2 o^2 / (o_a^2 +
// o_b^2)) of a correction: the side that reaches over gives way, as the larger structure does in
// the sharing by size.
std::vector<PairShares> sharesFromContactSides(std::span<const ContactSide> counts, Index n, Index minContacts = 100);

}  // namespace sinew

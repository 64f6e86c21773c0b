// Inputs the forces read besides the mesh store: images and what the user placed (attraction
// points, include / exclude points). Image-derived data (the gradient volume) is built the first time a force asks for it,
// so a scene without image forces allocates none.
#pragma once

#include "sinew/core/image.h"
#include "sinew/core/spatial_map.h"

#include <array>
#include <memory>
#include <string>
#include <vector>

namespace sinew {

// A point the user requires inside (include) or outside (exclude) a structure, world mm.
struct ConstraintPoint {
  Vec3 at = Vec3::Zero();
  bool include = true;
  bool operator==(const ConstraintPoint&) const = default;
};

class SceneData {
public:
  void setTargetImage(std::shared_ptr<const Image3D> image);
  void setTrainingImage(std::shared_ptr<const Image3D> image);
  bool hasTargetImage() const { return target_ != nullptr; }
  // Throws InputError when the scene has no image.
  const Image3D& targetImage() const;
  // The training image, or the target image when none was given. Throws std::logic_error after
  // releaseTrainingImage().
  const Image3D& trainingImage() const;
  // Lets the training image go once no force will train again (sinew-run: after the finest level's
  // training). Its memory is freed when no one else holds it (the demo's 0.5 mm atlas: 141 MB).
  void releaseTrainingImage();

  // Where a point of the target's space lies in the training image: the inverse of the scene's
  // initialisation (the reference shapes are mapped into the target, the training image is not).
  // Forces that train on the training image along the reference shape sample it through this.
  void setTrainingMap(const SpatialMap& targetToTraining) { trainingMap_ = targetToTraining; }
  Vec3 toTraining(const Vec3& targetPoint) const { return trainingMap_.apply(targetPoint); }
  // Whether that map is affine (straight lines stay straight and evenly sampled).
  bool trainingMapIsAffine() const { return !trainingMap_.hasSpline(); }

  // World-space gradient of the target image smoothed with sigmaMm; built on first request.
  const VectorVolume& targetGradient(float sigmaMm);

  // Bytes held by data derived from images (not the images themselves).
  std::size_t imageDerivedBytes() const;

  // Attraction points per structure (paper 000 section 4.5), in world millimetres.
  std::vector<std::vector<Vec3>>& attractionPoints() { return attractionPoints_; }
  const std::vector<std::vector<Vec3>>& attractionPoints() const { return attractionPoints_; }
  // Include / exclude points per structure (paper 001 section 4): the structure is pushed until
  // each include point lies inside it and each exclude point outside.
  std::vector<std::vector<ConstraintPoint>>& constraintPoints() { return constraintPoints_; }
  const std::vector<std::vector<ConstraintPoint>>& constraintPoints() const { return constraintPoints_; }

  // Deforming contacts (paper 001 section 2.2): the structure pairs the force `contacts` links.
  std::vector<std::array<Index, 2>>& contactPairs() { return contactPairs_; }
  const std::vector<std::array<Index, 2>>& contactPairs() const { return contactPairs_; }

  // The collision's shares by pair (scene key `collision_shares`): a vertex of `a` against `b` takes
  // `aShare` of each correction, one of `b` against `a` takes `bShare`.
  struct PairShare {
    Index a = -1, b = -1;
    float aShare = 1.0f, bShare = 1.0f;
  };
  std::vector<PairShare>& collisionShares() { return collisionShares_; }
  const std::vector<PairShare>& collisionShares() const { return collisionShares_; }

  // The structures' names in store order, for messages that name them.
  void addStructureName(const std::string& name) { structureNames_.push_back(name); }
  std::string structureName(Index m) const {
    return m >= 0 && m < Index(structureNames_.size()) ? structureNames_[m] : "#" + std::to_string(m);
  }

private:
  std::shared_ptr<const Image3D> target_, training_;
  std::unique_ptr<VectorVolume> gradient_;
  float gradientSigma_ = -1.0f;
  std::vector<std::vector<Vec3>> attractionPoints_;
  std::vector<std::vector<ConstraintPoint>> constraintPoints_;
  std::vector<std::array<Index, 2>> contactPairs_;
  SpatialMap trainingMap_;  // identity unless the scene was initialised
  std::vector<std::string> structureNames_;
  bool trainingReleased_ = false;  // the members before it keep their places (plugin ABI)
  std::vector<PairShare> collisionShares_;  // after it, for the same reason
};

}  // namespace sinew

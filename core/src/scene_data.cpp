#include "sinew/core/scene_data.h"

#include <stdexcept>

namespace sinew {

void SceneData::setTargetImage(std::shared_ptr<const Image3D> image) {
  target_ = std::move(image);
  gradient_.reset();
}

void SceneData::setTrainingImage(std::shared_ptr<const Image3D> image) {
  training_ = std::move(image);
  trainingReleased_ = false;
}

void SceneData::releaseTrainingImage() {
  training_.reset();
  trainingReleased_ = true;
}

const Image3D& SceneData::targetImage() const {
  if (!target_) throw InputError("the scene has no image, but an image force is active");
  return *target_;
}

const Image3D& SceneData::trainingImage() const {
  // Not the target in its place: a force training after the release would learn the wrong image.
  if (trainingReleased_) throw std::logic_error(
        "a force read the training image after it was released (SceneRunner lets it go once the finest level "
        "is trained; a force must train by then)");
  return training_ ? *training_ : targetImage();
}

const VectorVolume& SceneData::targetGradient(float sigmaMm) {
  if (!gradient_ || gradientSigma_ != sigmaMm) {
    gradient_ = std::make_unique<VectorVolume>(worldGradient(targetImage(), sigmaMm));
    gradientSigma_ = sigmaMm;
  }
  return *gradient_;
}

std::size_t SceneData::imageDerivedBytes() const { return gradient_ ? gradient_->bytes() : 0; }

}  // namespace sinew

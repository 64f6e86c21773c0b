// Intensity-profile force (paper 000 section 3.2.2, paper 001): each vertex has a reference profile
// sampled along the reference shape's normal in a training image; the search slides a window of
// the same length along the current normal in the target image and pulls the vertex to the offset
// with the highest normalised cross-correlation (NCC) against its reference.
#include "sinew/core/image_fit.h"
#include "sinew/core/registry.h"

#include <cmath>
#include <string>
#include <vector>

namespace sinew {

namespace {
const std::string kChannel = "intensity_profile.reference";

// The windows' sums side by side (window j starts at line[j]): each window adds its samples in the
// same order as one window at a time would, so the scores are the same bit for bit, but the loop
// over windows vectorises. Built twice where GCC can (x86-64): for AVX2, whose vectors are twice as
// wide, and for any x86-64, chosen at load time. The sums are the same either way (per window,
// in the same order, no fused multiply-add: -ffp-contract=off). On the 2-core Xeon the demo's CPU
// simulation took about 16 % less with the clones (docs/benchmarks.md); part of that came with the
// AVX2 clone's closing vzeroupper alone, for reasons not established. Not under ThreadSanitizer:
// the clones' resolver runs while the program loads, before TSan starts, and crashed it there.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(__SANITIZE_THREAD__)
__attribute__((target_clones("avx2", "default")))
#endif
void windowSums(const float* __restrict line, const float* __restrict ref, int length, int windows,
                float* __restrict sum, float* __restrict sum2, float* __restrict dot) {
  for (int k = 0; k < length; ++k) {
    const float r = ref[k];
    const float* __restrict w = &line[k];
    for (int j = 0; j < windows; ++j) {
      sum[j] += w[j];
      sum2[j] += w[j] * w[j];
      dot[j] += w[j] * r;
    }
  }
}

class IntensityProfileForce final : public Force, public ImageFit {
public:
  Requirements requirements() const override {
    return {.attributes = {Attribute::Normal, Attribute::ReferenceNormal}, .referenceShape = true, .imageForce = true};
  }

  // Trains the reference profiles from the training image and the reference shape (once per level).
  void prepare(ForceContext& ctx) override {
    readLayout(ctx.params);
    MeshStore& s = ctx.store;
    const Image3D& training = ctx.scene.trainingImage();
    const auto ref = s.referencePositions();
    const auto refNormal = s.referenceNormals();
    auto profiles = s.requireChannel(kChannel, length_, MemoryCategory::ImageDerived);
    // Through an affine map the samples stay evenly spaced on a line: its two first points mapped,
    // the rest sampled as a line in index space (Volume::sampleLine, as the search does; 2.2 times
    // faster at 325,632 vertices on 2 cores, the same accuracy); a spline maps each sample. The
    // step, a difference of two mapped points, is good to about 1e-3 voxel at the line's far end.
    const bool affine = ctx.scene.trainingMapIsAffine();
    ctx.executor.forEach(s.vertexCount(), [&](Index v) {
      float* prof = &profiles[static_cast<size_t>(v) * length_];
      if (affine) {
        const Vec3 first = training.worldToIndex(ctx.scene.toTraining(ref[v] + offset(0) * refNormal[v]));
        const Vec3 second = training.worldToIndex(ctx.scene.toTraining(ref[v] + offset(1) * refNormal[v]));
        training.sampleLine(first, second - first, length_, prof);
      } else {
        for (int k = 0; k < length_; ++k)
          prof[k] = training.sample(ctx.scene.toTraining(ref[v] + offset(k) * refNormal[v]));
      }
      normalise(prof);
    }, 1024);
  }

  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    MeshStore& s = ctx.store;
    const ParamTable& p = ctx.params;
    const int kDepth = p.indexOf("search_depth");
    const Image3D& image = ctx.scene.targetImage();
    const auto x = s.positions();
    const auto normal = s.normals();
    const auto meshOf = s.meshOfVertex();
    const auto profiles = s.channel(kChannel);
    forActiveVertices(ctx, [&](Index v, float alpha) {
      const float* ref = &profiles[static_cast<size_t>(v) * length_];
      const int reach = static_cast<int>(std::floor(p.getf(meshOf[v], kDepth) / spacing_));
      thread_local std::vector<float> line;
      line.resize(length_ + 2 * reach);
      // In index space, as the CUDA kernel's searchLine: sample q at start + q * step, without the
      // clamps where the whole line is inside (Volume::sampleLine; the demo's simulation stage
      // about 1.2-1.4 times faster than with a world-to-index product and clamps per sample).
      const Vec3 step = spacing_ * image.worldToIndexDirection(normal[v]);
      const Vec3 start = image.worldToIndex(x[v]) + (static_cast<float>(-inside_ - reach) + 0.5f) * step;  // offset(0) - reach
      image.sampleLine(start, step, static_cast<int>(line.size()), line.data());
      // Window j + reach starts at line[j + reach] (windowSums).
      const int windows = 2 * reach + 1;
      thread_local std::vector<float> sums;
      sums.assign(3 * static_cast<size_t>(windows), 0.0f);
      float* sum = sums.data();
      float* sum2 = sum + windows;
      float* dot = sum2 + windows;
      windowSums(line.data(), ref, length_, windows, sum, sum2, dot);
      float best = -2.0f;
      int bestJ = 0;
      for (int j = -reach; j <= reach; ++j) {
        const int i = j + reach;
        // ref has zero mean and unit norm, so NCC = dot / ||w - mean(w)||. A flat reference (all
        // zeros) scores 0 everywhere and the tie rule keeps the vertex in place.
        const float var = sum2[i] - sum[i] * sum[i] / static_cast<float>(length_);
        const float ncc = var > 1e-12f ? dot[i] / std::sqrt(var) : -1.0f;
        if (ncc > best || (ncc == best && std::abs(j) < std::abs(bestJ))) {
          best = ncc;
          bestJ = j;
        }
      }
      forces[v] += alpha * (static_cast<float>(bestJ) * spacing_) * normal[v];
    });
  }

  // Where each vertex lies: the NCC of its profile with the trained one, and the mean NCC of its
  // profile with two parallel lines 2 voxels away on either side along the surface, toward its
  // first neighbour (the share of the line that is signal, not noise: nearer lines would share
  // their voxels, and so their noise, through the trilinear interpolation).
  void fitScores(ForceContext& ctx, std::span<float> match, std::span<float> agreement) override {
    MeshStore& s = ctx.store;
    const Image3D& image = ctx.scene.targetImage();
    const auto x = s.positions();
    const auto normal = s.normals();
    const auto profiles = s.channel(kChannel);
    const auto neighbours = s.neighbours();
    forActiveVertices(ctx, [&](Index v, float) {
      thread_local std::vector<float> lines;
      lines.resize(3 * static_cast<size_t>(length_));
      const Vec3 n = normal[v];
      const Vec3 step = spacing_ * image.worldToIndexDirection(n);
      const Vec3 start = image.worldToIndex(x[v]) + (static_cast<float>(-inside_) + 0.5f) * step;  // offset(0)
      Vec3 along = x[neighbours[v][0]] - x[v];
      along = (along - along.dot(n) * n).normalized();
      const Vec3 alongIndex = image.worldToIndexDirection(along);
      const float apart = 2.0f / std::max(alongIndex.cwiseAbs().maxCoeff(), 1e-6f);  // mm to cross 2 voxels
      image.sampleLine(start, step, length_, &lines[0]);
      image.sampleLine(start + apart * alongIndex, step, length_, &lines[length_]);
      image.sampleLine(start - apart * alongIndex, step, length_, &lines[2 * length_]);
      for (int k = 0; k < 3; ++k) normalise(&lines[k * static_cast<size_t>(length_)]);
      const auto dot = [&](const float* a, const float* b) {
        float d = 0.0f;
        for (int k = 0; k < length_; ++k) d += a[k] * b[k];
        return d;
      };
      match[v] = dot(&lines[0], &profiles[static_cast<size_t>(v) * length_]);
      agreement[v] = 0.5f * (dot(&lines[0], &lines[length_]) + dot(&lines[0], &lines[2 * length_]));
    });
  }

  // The best match is held for the step: a pull toward it along the normal.
  bool addJacobian(ForceContext& ctx, JacobianBlocks& jacobian) override {
    addNormalPullJacobian(ctx, jacobian);
    return true;
  }

private:
  void readLayout(const ParamTable& p) {
    inside_ = static_cast<int>(p.get(0, p.indexOf("inside_samples")));
    outside_ = static_cast<int>(p.get(0, p.indexOf("outside_samples")));
    spacing_ = p.getf(0, p.indexOf("spacing"));
    length_ = inside_ + outside_;
  }
  // Sample k sits (k - inside + 0.5) spacings along the normal: inside samples are negative.
  float offset(int k) const { return (static_cast<float>(k - inside_) + 0.5f) * spacing_; }
  void normalise(float* prof) const {
    float mean = 0.0f;
    for (int k = 0; k < length_; ++k) mean += prof[k];
    mean /= static_cast<float>(length_);
    float norm2 = 0.0f;
    for (int k = 0; k < length_; ++k) norm2 += (prof[k] - mean) * (prof[k] - mean);
    const float inv = norm2 > 1e-12f ? 1.0f / std::sqrt(norm2) : 0.0f;
    for (int k = 0; k < length_; ++k) prof[k] = (prof[k] - mean) * inv;
  }

  int inside_ = 25, outside_ = 5, length_ = 30;
  float spacing_ = 0.5f;
};
}  // namespace

void registerIntensityProfileForce(Registry& registry) {
  registry.addForce(
      {"intensity_profile",
       "toward the offset along the normal whose profile best matches (NCC) the trained one",
       {{"inside_samples", 25, 1, 200, "", "profile samples inside the surface", false},
        {"outside_samples", 5, 1, 200, "", "profile samples outside the surface", false},
        {"spacing", 0.5, 0.05, 10.0, "mm", "distance between profile samples", false},
        {"search_depth", 5.0, 0.0, 50.0, "mm", "how far to search on each side of the surface"}},
       [] { return std::make_unique<IntensityProfileForce>(); }});
}

}  // namespace sinew

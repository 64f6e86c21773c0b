#include "collision_scenes.h"

#include "sinew/core/collision_tree.h"
#include "sinew/core/voxelize.h"

#include <algorithm>

namespace sinew::testing {
namespace {

// A stand-in for an image force that holds a boundary inside another structure: a constant push
// along +x of structure 0's cap beyond x = 8 mm (alpha times the vertex's mass, as the collision
// pull scales).
class PressForce final : public Force {
public:
  Requirements requirements() const override { return {.attributes = {Attribute::Mass}}; }
  void accumulate(ForceContext& ctx, std::span<Vec3> forces) override {
    const float alpha = ctx.params.getf(0, 0);
    const auto mass = ctx.store.masses();
    const auto x = ctx.store.positions();
    const MeshRange& r = ctx.store.range(0);
    for (Index v = r.vertexBegin; v < r.vertexEnd; ++v)
      if (x[v].x() > 8.0f) forces[v] += alpha * mass[v] * Vec3(1, 0, 0);
  }
};
const Registry& pressRegistry() {
  static const Registry registry = [] {
    Registry r;
    registerBuiltinForces(r);
    r.addForce({"press", "pushes structure 0 along +x", {}, [] { return std::make_unique<PressForce>(); }});
    return r;
  }();
  return registry;
}

}  // namespace

std::unique_ptr<Simulation> collidingSpheres(float gap, float weight, float innerRadius, const std::string& integrator,
                                             double timeStep, double sizeShare, double reaction) {
  auto sim = std::make_unique<Simulation>(forceRegistry(), 2);
  addSpherePair(*sim, gap, innerRadius);
  sim->addForce("shape_prior");
  if (weight > 0.0f) {
    ParamTable& collision = sim->addForce("collision");
    collision.setAll("weight", weight);
    collision.setAll("size_share", sizeShare);
    collision.setAll("reaction", reaction);
  }
  sim->setIntegrator(integrator).set(0, "time_step", timeStep);
  sim->initialize();
  return sim;
}

double pairOverlap(Simulation& sim) { return overlapVolume(tessellationOf(sim.store(), 0), tessellationOf(sim.store(), 1), 0.5); }

double reachAlongX(Simulation& sim, Index m, float sign) {
  float best = -1e30f;
  const MeshRange& r = sim.store().range(m);
  for (Index v = r.vertexBegin; v < r.vertexEnd; ++v) best = std::max(best, sign * sim.store().positions()[v].x());
  return double(best);
}

double largestStep(Simulation& sim) {
  double worst = 0.0;
  for (Index v = 0; v < sim.store().vertexCount(); ++v)
    worst = std::max(worst, double((sim.store().positions()[v] - sim.store().previousPositions()[v]).norm()));
  return worst;
}

std::vector<double> largestStepPerHundred(Simulation& sim, int blocks) {
  std::vector<double> out;
  for (int b = 0; b < blocks; ++b) {
    double largest = 0.0;
    for (int i = 0; i < 100; ++i) {
      sim.step();
      largest = std::max(largest, largestStep(sim));
    }
    out.push_back(largest);
  }
  return out;
}

namespace {
// Structure a pressed into b (pressedCap), each its own reference shape; b's collision weight given.
std::unique_ptr<Simulation> pressInto(StructureSpec a, StructureSpec b, double weightB, double hold, int steps,
                                      double reaction = 0.0) {
  auto sim = std::make_unique<Simulation>(pressRegistry(), 2);
  for (StructureSpec* s : {&a, &b}) {
    s->referencePositions = s->initialPositions;
    sim->addStructure(std::move(*s));
  }
  sim->addForce("shape_prior");
  ParamTable& press = sim->addForce("press");
  press.set(0, "weight", 0.1);
  press.set(1, "weight", 0.0);
  ParamTable& collision = sim->addForce("collision");
  collision.set(0, "weight", 0.5);
  collision.set(1, "weight", weightB);
  collision.setAll("hold_mm", hold);
  collision.setAll("reaction", reaction);
  sim->setIntegrator("damped_verlet").set(0, "time_step", 0.5);
  sim->initialize();
  sim->run(steps);
  return sim;
}
}  // namespace

std::unique_ptr<Simulation> pressedCap(float radiusA, Vec3 centreA, float radiusB, Vec3 centreB, double hold,
                                       int steps) {
  return pressInto(sphereStructure("a", 3, radiusA, centreA), sphereStructure("b", 3, radiusB, centreB), 0.0, hold,
                   steps);
}

std::unique_ptr<Simulation> pressedIntoCell(int steps, double reaction) {
  StructureSpec b = sphereStructure("b", 1, 30.0f, Vec3::Zero());
  const Vec3 facing = cellCentres(b.levels.levels[0], b.initialPositions)[0];
  const Eigen::Matrix3f turn = Eigen::Quaternionf::FromTwoVectors(facing, Vec3(-1, 0, 0)).toRotationMatrix();
  for (Vec3& p : b.initialPositions) p = turn * p + Vec3(8.4f + facing.norm(), 0, 0);
  return pressInto(sphereStructure("a", 3, 5.0f, Vec3(3.5f, 0, 0)), std::move(b), 0.5, 0.1, steps, reaction);
}

double deepestInside(Simulation& sim, Index own, Index other) {
  CollisionTree tree = CollisionTree::build(sim.store());
  const collision::BvhView view = tree.view();
  MeshStore& s = sim.store();
  const collision::P3* x = asP3(s.positions());
  double deepest = 0.0;
  for (Index v = s.range(own).vertexBegin; v < s.range(own).vertexEnd; ++v) {
    const collision::Hit h = collision::closestPoint(view, int(other), x[v], x, asP3(s.cellCentres()), 3.0e38f);
    deepest = std::max(deepest, double(-h.side));
  }
  return deepest;
}

}  // namespace sinew::testing

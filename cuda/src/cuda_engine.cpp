// The CUDA engine: mirrors the host mesh store on the device and runs whole batches of steps there,
// captured once as a CUDA Graph and replayed.
#include "sinew/cuda/cuda_engine.h"

#include "cuda_check.h"
#include "device_attachments.h"
#include "device_collision.h"
#include "device_forces.h"
#include "device_contour.h"
#include "device_error.h"
#include "device_image.h"
#include "device_placed.h"
#include "device_radial.h"
#include "device_step_blocks.h"
#include "device_store.h"
#include "kernels.h"
#include "step_graphs.h"

#include <algorithm>

namespace sinew::cuda {

using Kind = ForceKind;  // built-in forces have kernels here; a plugin's force brings its own (DeviceForce)

struct CudaEngine::Impl {
  Simulation& sim;
  cudaStream_t stream = nullptr;
  StreamBranch branch;  // the collision response beside the other forces (enqueueStep)
  std::string device;
  std::vector<ForceSlot> forces;
  // Mesh store mirror.
  DeviceTopology topology;
  DeviceStepBlocks stepBlocks;  // launchStepInBlocks' connectivity, for the lean step of large scenes
  DeviceArray<int> meshBegin, meshEnd;
  std::vector<int> hostMeshBegin;  // the current level's vertex ranges, for the next level change
  DeviceArray<float> density, massFloor, elevation, area, mass;
  DeviceArray<float3> x, prev, force, normal, centre;
  // With the hierarchies: a third position buffer, for the collision's hold in the profile's pass
  // (ContactPlanes::heldPrevious); then x, prev and it rotate (enqueueStep, run).
  DeviceArray<float3> thirdPositions;
  DeviceArray<float4> reference;
  // Implicit Euler: per-structure Jacobian weights and the solver's work arrays.
  DeviceArray<float> meshPull, meshNormalPull, implicitA, implicitB, implicitOff, implicitC;
  DeviceArray<float3> implicitVel, implicitRhs, implicitR, implicitZ, implicitP, implicitAp;
  DeviceArray<double> implicitScalars;
  // Image-derived data, only when a force needs it.
  DeviceImageTexture imageTexture;  // the profile force's target image
  DeviceArray<float> profiles;
  DeviceArray<float3> gradient;
  DeviceArray<float3> imageForce;  // the image forces alone, while the affine regularisation is on
  DeviceArray<double> affineMoments, affineCoefficients;
  int affineParts = 1;  // blocks per structure summing the normal equations
  std::vector<std::unique_ptr<CoarseLevel>> coarseLevels;  // while multi-resolution forces are on
  int coarseLevelsAt = -1;                                  // the level they were built for
  VolumeView imageView{}, gradientView{};
  float gradientSigma = -1.0f;
  // The profile layout the profiles were trained with (read at upload, after training), as the CPU
  // force keeps it from its prepare().
  int profileInside = 0, profileOutside = 0;
  float profileSpacing = 0.0f;
  DevicePlacedPoints placedPoints;  // attraction, include and exclude points
  DeviceCollision collision;        // built while the collision force is active, per level
  int collisionAhead = 0;           // steps captured so far in the batch (DeviceCollision::searchesAt)
  DeviceContactLinks contactLinks;  // built while the contacts force is active, per level
  DeviceRadial radial;              // medial surfaces of the structures the radial force acts on
  DeviceAttachments attachments;    // the level's attachments (Simulation builds them per level)
  DeviceSampledError sampledError;  // used when a run samples its error on the device
  DeviceContour contour;            // the slice views' contours
  MeshView view;
  StepGraphs graphs;                       // the captured batches of steps
  std::vector<float> graphSignature;       // what the captured graphs baked in

  explicit Impl(Simulation& s) : sim(s) {}
  ~Impl() {
    invalidateGraph();
    if (stream) cudaStreamDestroy(stream);
  }

  void uploadParams() {
    for (ForceSlot& f : forces) {
      const ParamTable& t = sim.forceParams(f.name);
      std::vector<float> v(static_cast<size_t>(t.rows()) * t.decls().size());
      for (Index r = 0; r < t.rows(); ++r)
        for (size_t p = 0; p < t.decls().size(); ++p) v[r * t.decls().size() + p] = t.getf(r, static_cast<int>(p));
      f.count = static_cast<int>(t.decls().size());
      f.params.upload(v, stream);
    }
    if (placedPoints.upload(sim.scene(), stream)) invalidateGraph();
    for (const ForceSlot& f : forces)
      if (f.kind == Kind::Gradient) uploadGradient(f);
    if (implicit()) uploadJacobianWeights();
  }

  bool implicit() const { return sim.integratorName() == "implicit_euler"; }

  // The collision force's slot while it is active and built, else null.
  const ForceSlot* activeCollision() const {
    for (const ForceSlot& f : forces)
      if (f.kind == Kind::Collision) return collision.built() && sim.forceParams(f.name).anyPositive(0) ? &f : nullptr;
    return nullptr;
  }
  // The collision hierarchies, built on first use at each level (before any capture) and only for
  // two or more structures.
  void prepareCollision() {
    for (const ForceSlot& f : forces)
      if (f.kind == Kind::Collision && !collision.built() && sim.store().meshCount() >= 2 &&
          sim.forceParams(f.name).anyPositive(0)) {
        collision.build(sim.store(), sim.scene(), sim.forceParams(f.name), implicit(), stream);
        invalidateGraph();
      } else if (f.kind == Kind::Collision && collision.built() && collision.prepareReaction(sim.forceParams(f.name), stream))
        invalidateGraph();  // the reaction turned on within the level
    const size_t third = collision.built() ? size_t(sim.store().vertexCount()) : 0;
    if (thirdPositions.size() != third) {
      thirdPositions.resize(third);
      invalidateGraph();
    }
  }
  // The position buffer that is neither view.x nor view.prev (the third allocated above).
  float3* spareBuffer() {
    for (DeviceArray<float3>* a : {&x, &prev, &thirdPositions})
      if (a->get() != view.x && a->get() != view.prev) return a->get();
    return nullptr;
  }

  bool contactsActive() const {
    for (const ForceSlot& f : forces)
      if (f.kind == Kind::Contacts) return contactLinks.built() && sim.forceParams(f.name).anyPositive(0);
    return false;
  }
  // The level's contact links, found on the host's reference shapes on first use at each level,
  // before any capture.
  void prepareContacts() {
    for (const ForceSlot& f : forces)
      if (f.kind == Kind::Contacts && !contactLinks.built() && sim.forceParams(f.name).anyPositive(0)) {
        const ParamTable& t = sim.forceParams(f.name);
        contactLinks.build(sim.store(), sim.scene(), t.getf(0, t.indexOf("distance_mm")), implicit(), stream);
        invalidateGraph();
      }
  }

  bool radialActive() const {
    for (const ForceSlot& f : forces)
      if (f.kind == Kind::Radial) return sim.forceParams(f.name).anyPositive(0);
    return false;
  }
  // The radial force's medial surfaces, for every structure it acts on now (before any capture).
  void prepareRadial() {
    for (const ForceSlot& f : forces)
      if (f.kind == Kind::Radial && sim.forceParams(f.name).anyPositive(0) &&
          radial.update(sim, sim.forceParams(f.name), view, implicit(), stream))
        invalidateGraph();
  }

  // As the CPU forces' addJacobian: smoothing and the shape prior pull toward the neighbours, the
  // image forces along the normal; a force weighted 0 everywhere adds nothing.
  void uploadJacobianWeights() {
    const Index meshes = sim.structureCount();
    std::vector<float> pull(meshes, 0.0f), normalPull(meshes, 0.0f);
    for (const ForceSlot& f : forces) {
      const ParamTable& t = sim.forceParams(f.name);
      if (!t.anyPositive(0)) continue;
      std::vector<float>* target = f.kind == Kind::Smoothing || f.kind == Kind::ShapePrior ? &pull
                                   : f.kind == Kind::Gradient || f.kind == Kind::Profile    ? &normalPull
                                                                                             : nullptr;
      if (!target) continue;  // attraction points stay explicit, as on the CPU
      for (Index m = 0; m < meshes; ++m) (*target)[m] += std::max(0.0f, t.getf(m, 0));
    }
    meshPull.upload(pull, stream);
    meshNormalPull.upload(normalPull, stream);
  }

  // The coarser levels of the current one (multi-resolution forces), from the simulation's host
  // stores of them: topology, reference parameters, the gather and prolongation indices.
  void uploadCoarseLevels() {
    coarseLevels.clear();
    const int L = sim.level();
    const std::vector<int> fineBegin = meshBegins(sim, L);
    for (int l = 0; l < L; ++l) coarseLevels.push_back(CoarseLevel::upload(sim, l, fineBegin, stream));
    coarseLevelsAt = L;
    invalidateGraph();
  }

  // The shape forces on every coarser level, carried up and added with the weight (Horner: each
  // level's forces go up one level into the next one's, the last into the current forces).
  void enqueueCoarseForces(float weight) {
    for (auto& c : coarseLevels) {
      launchGather(c->gatherIndex.get(), c->view.vertices, view.x, c->view.x, stream);
      launchGeometry(c->view, c->topology.cellSpans.get(), stream);
      SINEW_CUDA(cudaMemsetAsync(c->force.get(), 0, c->force.bytes(), stream));
      for (const ForceSlot& f : forces) {
        const ParamTable& t = sim.forceParams(f.name);
        if (!t.anyPositive(0)) continue;
        const ParamView p{f.params.get(), f.count};
        if (f.kind == Kind::Smoothing) launchSmoothing(c->view, p, t.indexOf("elevation_term"), stream);
        if (f.kind == Kind::ShapePrior) launchShapePrior(c->view, p, c->reference.get(), stream);
      }
    }
    for (size_t l = 0; l < coarseLevels.size(); ++l) {
      const CoarseLevel& c = *coarseLevels[l];
      const bool last = l + 1 == coarseLevels.size();
      launchProlongAdd(c.upRows.get(), c.upIndex.get(), c.upWeight.get(), c.upCount, c.force.get(),
                       last ? view.force : coarseLevels[l + 1]->force.get(), last ? weight : 1.0f, stream);
    }
  }

  void invalidateGraph() { graphs.clear(); }

  // The gradient volume depends on the shared sigma; the CPU rebuilds it when sigma changes, so
  // does the engine.
  void uploadGradient(const ForceSlot& f) {
    const ParamTable& t = sim.forceParams(f.name);
    const float sigma = t.getf(0, t.indexOf("sigma"));
    if (sigma == gradientSigma && gradient.size()) return;
    const VectorVolume& g = sim.scene().targetGradient(sigma);
    gradient.upload(reinterpret_cast<const float3*>(g.voxels().data()), g.voxels().size(), stream);
    gradientView = viewOf(g.geometry());
    gradientSigma = sigma;
    invalidateGraph();
  }

  // The host's positions and previous positions (sizes unchanged within a level: the buffers, and so
  // the captured graphs, stay).
  void uploadState() {
    MeshStore& s = sim.store();
    uploadAs(x, s.positions(), stream);
    uploadAs(prev, std::span<const Vec3>(s.previousPositions()), stream);
  }

  void upload(bool state = true) {
    invalidateGraph();
    MeshStore& s = sim.store();
    s.refresh();  // reference parameters and trained profiles are computed on the host, once per level
    topology.upload(s, stream);
    // The lean step in one pass (launchStepInBlocks) for scenes of smoothing and the shape prior
    // alone, at the sizes where the geometry's pass would read the cell centres from memory.
    const bool shapeOnly = std::all_of(forces.begin(), forces.end(), [](const ForceSlot& f) {
      return f.kind == Kind::Smoothing || f.kind == Kind::ShapePrior;
    });
    if (!shapeOnly || geometryReadsCellSpans(int(s.vertexCount())) || !stepBlocks.upload(s, stream))
      stepBlocks.clear();
    std::vector<int> begin, end;
    std::vector<float> dens, floors;
    for (Index m = 0; m < s.meshCount(); ++m) {
      begin.push_back(s.range(m).vertexBegin);
      end.push_back(s.range(m).vertexEnd);
      dens.push_back(s.density(m));
      floors.push_back(s.massFloor(m));
    }
    meshBegin.upload(begin, stream);
    hostMeshBegin = begin;
    meshEnd.upload(end, stream);
    density.upload(dens, stream);
    massFloor.upload(floors, stream);
    if (state) uploadState();
    force.resize(s.vertexCount());
    if (s.has(Attribute::Normal)) normal.resize(s.vertexCount());
    if (s.has(Attribute::Elevation)) elevation.resize(s.vertexCount());
    if (s.has(Attribute::Area)) area.resize(s.vertexCount());
    if (s.has(Attribute::CellCentre)) centre.resize(s.cellCount());
    attachments.upload(sim.attachments().arrays(), stream);
    collision.clear();  // the level's topology: built again when the force runs
    contactLinks.clear();
    if (s.has(Attribute::Mass)) mass.resize(s.vertexCount());
    if (implicit()) {
      for (auto* a : {&implicitA, &implicitB, &implicitOff, &implicitC}) a->resize(s.vertexCount());
      for (auto* a : {&implicitVel, &implicitRhs, &implicitR, &implicitZ, &implicitP, &implicitAp}) a->resize(s.vertexCount());
      implicitScalars.resize(kImplicitScalars);
    }
    if (s.has(Attribute::ReferenceParams)) uploadReference(reference, s.referenceParams(), s.executor(), stream);
    for (const ForceSlot& f : forces) {
      if (f.kind == Kind::Profile) {
        const Image3D& im = sim.scene().targetImage();
        imageView = viewOf(im.geometry());
        if (imageTexture.source() != im.voxels().data())  // the same image at every level
          imageTexture.upload(im.voxels().data(), imageView.sx, imageView.sy, imageView.sz, stream);
        const auto ch = s.channel("intensity_profile.reference");
        profiles.upload(ch.data(), ch.size(), stream);
        const ParamTable& t = sim.forceParams(f.name);
        profileInside = static_cast<int>(t.get(0, t.indexOf("inside_samples")));
        profileOutside = static_cast<int>(t.get(0, t.indexOf("outside_samples")));
        profileSpacing = t.getf(0, t.indexOf("spacing"));
      }
      if (f.kind == Kind::Gradient) {
        gradientSigma = -1.0f;
        uploadGradient(f);
      }
    }
    view = MeshView{};
    topology.bind(s, view);
    view.density = density.get();
    view.massFloor = massFloor.get();
    view.x = x.get();
    view.prev = prev.get();
    view.force = force.get();
    view.normal = s.has(Attribute::Normal) ? normal.get() : nullptr;
    view.elevation = s.has(Attribute::Elevation) ? elevation.get() : nullptr;
    view.area = s.has(Attribute::Area) ? area.get() : nullptr;
    view.mass = s.has(Attribute::Mass) ? mass.get() : nullptr;
    view.cellCentre = s.has(Attribute::CellCentre) ? centre.get() : nullptr;
    uploadParams();
    for (ForceSlot& f : forces)
      if (f.kind == Kind::Plugin) checkPlugin(f, f.device->prepare(pluginContext(f)), "prepare");
    SINEW_CUDA(cudaStreamSynchronize(stream));
  }

  DeviceForceContext pluginContext(const ForceSlot& f) {
    return DeviceForceContext{view, ParamView{f.params.get(), f.count}, sim.forceParams(f.name), stream};
  }
  static void checkPlugin(const ForceSlot& f, cudaError_t e, const char* what) {
    if (e != cudaSuccess)
      throw std::runtime_error("force '" + f.name + "': its device path failed to " + what + ": " + cudaGetErrorString(e));
  }

  // One step, as Simulation::step: geometry, forces with a positive weight somewhere, Verlet. The
  // leading per-vertex forces run fused in one kernel; the others follow in order. keepForces: the
  // step's forces must be left in `force` (a batch's last step: the host downloads them).
  void enqueueStep(bool keepForces) {
    // With the affine regularisation on, the image forces add into their own buffer (the gradient
    // then runs apart from the fused kernel), which is regularised into the force at the end.
    const float share = sim.affineRegularisation();
    const bool regularise = share > 0.0f;
    MeshView imageTarget = view;
    if (regularise) {
      imageTarget.force = imageForce.get();
      SINEW_CUDA(cudaMemsetAsync(imageForce.get(), 0, imageForce.bytes(), stream));
    }
    size_t next = 0;
    FusedTerms fused = fusedPrefix(forces, sim, regularise, next);
    fused.reference = reference.get();
    fused.gradient = gradient.get();
    fused.gradientVolume = gradientView;
    // Damped Verlet runs in the profile kernel's pass when the profile is the step's last force
    // and nothing else comes between the forces and the move.
    const auto activeAfter = [&](size_t i) { return cuda::activeAfter(forces, sim, i); };
    const bool moveAlone = implicit() || regularise || !coarseLevels.empty() || !attachments.empty();
    VerletMove move{};
    if (!moveAlone) {
      const ParamTable& ip = sim.integratorParams();
      move = {ip.getf(0, ip.indexOf("time_step")), 1.0f - ip.getf(0, ip.indexOf("damping"))};
    }
    // When the fused terms are the only forces, the move joins their pass; when the profile is the
    // only other one and the move joins it, the fused terms join that pass. One launch instead of
    // two: the new positions are written aside, so x and prev swap.
    size_t profile = next;
    while (profile < forces.size() && !sim.forceParams(forces[profile].name).anyPositive(0)) ++profile;
    // The collision's schedule (DeviceCollision::searchesAt, asked once a step). Between full
    // searches, where the collision is the only force after the profile, its contact planes and
    // hold join the profile's pass (small scenes), or the planes add to the profile's term before
    // the terms' pass and the hold follows the move (larger ones).
    const ForceSlot* slot = activeCollision();
    const bool collide = slot != nullptr;
    const bool search = collide && collision.searchesAt(collisionAhead++, sim.forceParams(slot->name));
    const ParamView collisionParams = slot ? ParamView{slot->params.get(), slot->count} : ParamView{};
    const bool planesAfterProfile = collide && !search && onlyActiveAfter(forces, sim, profile, slot);
    ContactPlanes planes =
        planesAfterProfile ? collision.contactPlanes(collisionParams, sim.forceParams(slot->name)) : ContactPlanes{};
    // The reaction's sums, taken where the collision's force is added: summed by a full search's
    // response; between full searches on a branch beside the geometry's pass (they read only the
    // positions and the planes), joined before the profile's pass takes them.
    const ReactionSums reaction = collide ? collision.reactionSums(collisionParams, sim.forceParams(slot->name)) : ReactionSums{};
    const bool reactBeside = reaction.sums && !search;
    const auto geometryBesideReaction = [&](auto&& launch) {
      if (reactBeside) launchCollisionReaction(view, reaction, branch.begin(stream));
      launch();
      if (reactBeside) branch.join(stream);
    };
    planes.reaction = reaction.sums;
    // The geometry without what no kernel of the step reads (the lean geometry, docs/benchmarks.md):
    // the pass of the terms and the move computes the normals and masses itself.
    const bool lean = !moveAlone && !hasGradientTerm(fused) && view.area;
    const auto geometry = [&](bool normals, bool masses = false) {
      MeshView g = view;
      if (lean && !masses) g.mass = nullptr;
      if (lean && !normals) g.normal = nullptr;
      launchGeometry(g, topology.cellSpans.get(), stream);
    };
    // The blocks exist only in scenes of smoothing and the shape prior (upload): there the lean
    // terms' pass computes the geometry it reads too (launchStepInBlocks).
    const bool inBlocks = lean && stepBlocks.ready();
    const auto termsAndMove = [&] {
      MeshView m = view;
      if (lean) m.mass = nullptr;
      if (!keepForces) m.force = nullptr;  // nothing reads the step's forces before the batch's end
      if (inBlocks) launchStepInBlocks(m, stepBlocks.view(), fused, move, stream);
      else launchFusedForcesAndMove(m, fused, move, stream);
      std::swap(view.x, view.prev);
    };
    if (!moveAlone && profile == forces.size()) {
      if (!inBlocks) geometry(false);
      termsAndMove();
      return;
    }
    if (!moveAlone && !hasGradientTerm(fused) && profile < forces.size() && forces[profile].kind == Kind::Profile &&
        (!activeAfter(profile) || planesAfterProfile)) {
      const ForceSlot& f = forces[profile];
      const ParamTable& t = sim.forceParams(f.name);
      const ParamView p{f.params.get(), f.count};
      const int reach = maxProfileReach(t), kDepth = t.indexOf("search_depth");
      if (profileTakesTerms(view.vertices, profileInside, profileOutside, reach)) {
        // The hold in the pass too: the previous positions to the spare buffer, x to prev's.
        ContactPlanes inPass = planes;
        if (planes.hold) {
          inPass.hold = nullptr;
          inPass.heldPrevious = spareBuffer();
        }
        geometryBesideReaction([&] { launchGeometry(view, topology.cellSpans.get(), stream); });
        launchProfileAfterTerms(view, fused, p, kDepth, imageView, imageTexture.get(), profiles.get(), profileInside,
                                profileSpacing, reach, move, planesAfterProfile ? &inPass : nullptr, stream);
        std::swap(view.x, view.prev);
        if (inPass.heldPrevious) view.prev = inPass.heldPrevious;
        return;
      }
      // Larger scenes: the profile's term first, then the terms added to it in the move's pass, so
      // that the move needs no pass of its own.
      if (lean && profileGoesFirst(view.vertices, profileInside, profileOutside, reach)) {
        geometryBesideReaction([&] { geometry(true); });
        MeshView g = view;
        g.mass = nullptr;  // lean: the planes take the masses from the areas, as the terms' pass does
        launchProfileFirst(g, p, kDepth, imageView, imageTexture.get(), profiles.get(), profileInside, profileSpacing,
                           reach, planesAfterProfile ? &planes : nullptr, stream);
        fused.plus = view.force;
        termsAndMove();
        if (planes.hold) launchCollisionHold(view, collision.view(), planes.settings, stream);
        return;
      }
    }
    // The collision force writes a force of its own, on a branch beside the geometry (its refit, where
    // that computes the cells' centres itself) and the forces before it (its response), joined at its
    // place in the force order: its force added as the CPU adds it, or, as the last force before damped
    // Verlet, with the move and the hold in one pass (docs/collisions.md, "The response beside ...").
    // Between full searches the branch holds only the contact planes (launchCollisionPlanes).
    cudaStream_t side = search || reactBeside ? branch.begin(stream) : nullptr;
    const bool early = search && collision.refitsBeforeGeometry();
    if (early) collision.refit(view, side);
    if (reactBeside) launchCollisionReaction(view, reaction, side);
    launchGeometry(view, topology.cellSpans.get(), stream);
    collision::ContactSettings settings;  // its hold negative: no hold
    if (search) {
      branch.follow(stream);
      if (!early) collision.refit(view, side);
      settings = collision.respond(view, collisionParams, sim.forceParams(slot->name), side);  // the reaction too
    } else if (collide) {
      if (reactBeside) branch.follow(stream);
      else side = branch.begin(stream);
      const ContactPlanes c = collision.contactPlanes(collisionParams, sim.forceParams(slot->name));
      launchCollisionPlanes(view, c, collision.view().force, side);
      settings = c.settings;
    }
    bool joined = !collide, held = false, moved = false;
    const auto joinCollision = [&](size_t at) {
      if (joined) return;
      branch.join(stream);
      joined = true;
      if (moveAlone || activeAfter(at) || anyPluginActive(forces, sim)) return launchCollisionAdd(view, collision.view(), stream);
      launchCollisionMove(view, collision.view(), move, settings, stream);
      moved = held = true;
    };
    launchFusedForces(view, fused, stream);
    for (; next < forces.size(); ++next) {
      const ForceSlot& f = forces[next];
      const ParamTable& t = sim.forceParams(f.name);
      if (!t.anyPositive(0)) continue;
      const ParamView p{f.params.get(), f.count};
      switch (f.kind) {
        case Kind::Smoothing: launchSmoothing(view, p, t.indexOf("elevation_term"), stream); break;
        case Kind::ShapePrior: launchShapePrior(view, p, reference.get(), stream); break;
        case Kind::Gradient:
          launchGradient(imageTarget, p, t.indexOf("epsilon"), t.indexOf("search_depth"), t.indexOf("sample_spacing"),
                         gradientView, gradient.get(), stream);
          break;
        case Kind::Profile:
          moved = !moveAlone && !activeAfter(next) && !collide;  // the branch reads the positions
          launchProfile(imageTarget, p, t.indexOf("search_depth"), imageView, imageTexture.get(), profiles.get(), profileInside,
                        profileOutside, profileSpacing, maxProfileReach(t), moved ? &move : nullptr, stream);
          break;
        case Kind::Attraction:
          placedPoints.launch(view, p, t.indexOf("ring"), t.indexOf("margin_mm"), meshBegin.get(), meshEnd.get(), stream);
          break;
        case Kind::Collision: joinCollision(next); break;  // launched on the branch above
        case Kind::Contacts:
          contactLinks.launch(view, p, stream);
          break;
        case Kind::Radial: radial.launch(view, p, int(t.get(0, t.indexOf("medial_iterations"))), stream); break;
        case Kind::Plugin: checkPlugin(f, f.device->enqueue(pluginContext(f)), "enqueue"); break;
      }
    }
    joinCollision(forces.size());
    if (regularise)
      launchAffineRegularisation(view, imageForce.get(), meshBegin.get(), meshEnd.get(), sim.structureCount(),
                                 affineParts, affineMoments.get(), affineCoefficients.get(), share, stream);
    if (!coarseLevels.empty()) enqueueCoarseForces(sim.coarseForceWeight());
    if (!attachments.empty()) launchAttachmentShare(view, attachments.view(), stream);
    if (!moved) enqueueIntegrator();
    // The forces' constraints after the move (Force::constrain), in force order.
    for (const ForceSlot& f : forces) {
      if (f.kind == Kind::Collision && settings.hold >= 0.0f && !held)
        launchCollisionHold(view, collision.view(), settings, stream);
      if (f.kind == Kind::Plugin && sim.forceParams(f.name).anyPositive(0))
        checkPlugin(f, f.device->constrain(pluginContext(f)), "constrain");
    }
    if (!attachments.empty()) launchAttachmentProject(view, attachments.view(), stream);
  }

  void enqueueIntegrator() {
    const ParamTable& ip = sim.integratorParams();
    if (!implicit()) {
      launchVerlet(view, ip.getf(0, ip.indexOf("time_step")), 1.0f - ip.getf(0, ip.indexOf("damping")), stream);
      return;
    }
    ImplicitTerms terms{meshPull.get(), meshNormalPull.get(), activeCollision() ? collision.stiffness() : nullptr,
                        contactsActive() ? contactLinks.stiffness() : nullptr};
    if (radialActive()) radial.addTerms(terms);
    const ImplicitWork work{implicitA.get(), implicitB.get(), implicitOff.get(), implicitC.get(), implicitVel.get(),
                            implicitRhs.get(), implicitR.get(), implicitZ.get(), implicitP.get(), implicitAp.get(),
                            implicitScalars.get()};
    launchImplicitEuler(view, terms, work, ip.getf(0, ip.indexOf("time_step")), ip.getf(0, ip.indexOf("damping_rate")),
                        ip.get(0, ip.indexOf("cg_tolerance")), static_cast<int>(ip.get(0, ip.indexOf("cg_max_iterations"))),
                        stream);
  }
};

CudaEngine::CudaEngine(Simulation& simulation) : impl_(std::make_unique<Impl>(simulation)) {
  const DeviceStatus st = probeDevice();
  if (!st.usable) throw std::runtime_error(st.reason);
  impl_->device = st.description;
  if (simulation.integratorName() != "damped_verlet" && simulation.integratorName() != "implicit_euler")
    throw std::runtime_error("integrator '" + simulation.integratorName() + "' has no CUDA implementation");
  for (const std::string& name : simulation.forceNames()) {
    Kind kind = Kind::Plugin;
    const bool builtIn = builtInForceKind(name, kind);
    DeviceForce* device = builtIn ? nullptr : simulation.force(name).deviceForce();
    if (!builtIn && !device)
      throw std::runtime_error("force '" + name + "' has no CUDA implementation (its Force::deviceForce() gives none)");
    impl_->forces.push_back({name, kind, {}, 0, device});
  }
  SINEW_CUDA(cudaStreamCreateWithFlags(&impl_->stream, cudaStreamNonBlocking));
  impl_->upload();
}

CudaEngine::~CudaEngine() = default;

void CudaEngine::run(int iterations) {
  Impl& I = *impl_;
  // Multi-resolution forces: the coarser levels on the device, built once per level (before capture).
  const bool coarse = I.sim.coarseForceWeight() > 0.0f && I.sim.level() > 0;
  if (coarse)
    for (const auto& f : I.forces)
      if (f.kind == Kind::Plugin && I.sim.force(f.name).requirements().shapeForce)
        throw std::runtime_error("force '" + f.name + "': a plugin's shape force on the coarser levels has no CUDA path");
  if (coarse && I.coarseLevelsAt != I.sim.level()) I.uploadCoarseLevels();
  if (!coarse && !I.coarseLevels.empty()) {
    I.coarseLevels.clear();
    I.coarseLevelsAt = -1;
    I.invalidateGraph();
  }
  // The affine regularisation's buffers, allocated only while it is on (before any capture).
  if (I.sim.affineRegularisation() > 0.0f) {
    const void* before[3] = {I.imageForce.get(), I.affineMoments.get(), I.affineCoefficients.get()};
    I.imageForce.resize(I.sim.store().vertexCount());
    Index largest = 1;
    for (Index m = 0; m < I.sim.store().meshCount(); ++m) largest = std::max(largest, I.sim.store().range(m).vertexCount());
    I.affineParts = static_cast<int>((largest + kAffineChunk - 1) / kAffineChunk);
    I.affineMoments.resize(size_t(I.sim.structureCount()) * I.affineParts * 22);
    I.affineCoefficients.resize(size_t(I.sim.structureCount()) * 12);
    if (before[0] != I.imageForce.get() || before[1] != I.affineMoments.get() || before[2] != I.affineCoefficients.get())
      I.invalidateGraph();
  }
  const int total = iterations;
  I.uploadParams();
  I.prepareCollision();
  I.prepareContacts();
  I.prepareRadial();
  const std::vector<float> signature = graphSignature(I.forces, I.sim);
  if (signature != I.graphSignature) I.invalidateGraph();
  I.graphSignature = signature;
  // Batches of up to 32 steps (fewer for implicit Euler, below), each length captured once as a CUDA Graph and replayed (a report
  // interval of 10 replays a 10-step graph).
  // Implicit Euler captures 4 kernels per conjugate-gradient iteration in each step: fewer steps
  // per graph keep a graph near 4,000 nodes.
  const int cgIterations = I.implicit() ? static_cast<int>(I.sim.integratorParams().get(
                                              0, I.sim.integratorParams().indexOf("cg_max_iterations")))
                                        : 0;
  const int kBatch = std::clamp(4000 / (4 * cgIterations + 8), 1, 32);
  // The current positions back in x after the batches, for everything between runs (downloads,
  // drawing, sampling, the next level), also when a batch failed.
  // (Three buffers rotate where the collision's hold runs in the profile's pass.)
  const auto currentInX = [&] {
    for (DeviceArray<float3>* a : {&I.prev, &I.thirdPositions})
      if (a->get() == I.view.x) std::swap(*a, I.x);
    if (I.thirdPositions.get() == I.view.prev) std::swap(I.thirdPositions, I.prev);
  };
  try {
    for (; iterations > 0; iterations -= std::min(iterations, kBatch)) {
      const int n = std::min(iterations, kBatch);
      const ForceSlot* collisionSlot = I.activeCollision();
      const int schedule = collisionSlot ? I.collision.schedule(I.sim.forceParams(collisionSlot->name)) : 0;
      I.collisionAhead = 0;
      I.graphs.enqueue(n, schedule, I.view, I.stream, [&](bool last) { I.enqueueStep(last); });
      if (collisionSlot) I.collision.advance(n);
    }
  } catch (...) {
    currentInX();
    throw;
  }
  currentInX();
  SINEW_CUDA(cudaStreamSynchronize(I.stream));
  SINEW_CUDA(cudaGetLastError());
  I.sim.countExternalSteps(total);
}

void CudaEngine::download() {
  Impl& I = *impl_;
  MeshStore& s = I.sim.store();
  const size_t n = s.vertexCount();
  I.x.download(reinterpret_cast<float3*>(s.positionsForWrite().data()), n, I.stream);
  I.prev.download(reinterpret_cast<float3*>(s.previousPositions().data()), n, I.stream);
  I.force.download(reinterpret_cast<float3*>(s.forces().data()), n, I.stream);
  SINEW_CUDA(cudaStreamSynchronize(I.stream));
}

void CudaEngine::reload() { impl_->upload(); }

void CudaEngine::restoreState() {
  impl_->uploadState();
  impl_->collision.restart();  // the next step searches in full, as the CPU's force after a rollback
  SINEW_CUDA(cudaStreamSynchronize(impl_->stream));
}

bool CudaEngine::measureError(SampledError& error, std::vector<std::optional<SurfaceDistanceStats>>& out) {
  Impl& I = *impl_;
  out = I.sampledError.measure(error, I.sim.store(), I.view, I.stream);
  return true;
}

bool CudaEngine::closestDistances(const TriangleBvh& meshes, std::span<const collision::P3> points,
                                  std::span<const int> roots, std::span<float> out) {
  closestDistancesOnDevice(meshes, points, roots, out, impl_->stream);
  return true;
}

void CudaEngine::levelChanged() {
  Impl& I = *impl_;
  const Simulation& sim = I.sim;
  const MeshStore& fine = I.sim.store();
  // The coarse ranges are those of the last upload.
  const GlobalProlongation g = globalProlongation(sim, sim.level() - 1, I.hostMeshBegin);
  DeviceArray<int> dRows, dIndex;
  DeviceArray<float> dWeight;
  dRows.upload(g.rows, I.stream);
  dIndex.upload(g.index, I.stream);
  dWeight.upload(g.weight, I.stream);
  DeviceArray<float3> x(fine.vertexCount()), prev(fine.vertexCount());
  const int n = static_cast<int>(fine.vertexCount());
  launchProlong(dRows.get(), dIndex.get(), dWeight.get(), n, I.x.get(), x.get(), I.stream);
  launchProlong(dRows.get(), dIndex.get(), dWeight.get(), n, I.prev.get(), prev.get(), I.stream);
  SINEW_CUDA(cudaStreamSynchronize(I.stream));
  I.x = std::move(x);
  I.prev = std::move(prev);
  I.coarseLevels.clear();
  I.coarseLevelsAt = -1;
  I.upload(false);
}

namespace {
DrawRange drawRange(const MeshStore& s, Index mesh) {
  const MeshRange& r = s.range(mesh);
  return {int(r.vertexBegin), int(r.vertexEnd), int(r.cellBegin), int(r.cellEnd)};
}
}  // namespace

void CudaEngine::writeSurfacePoints(Index mesh, float* out) {
  Impl& I = *impl_;
  launchSurfacePoints(drawRange(I.sim.store(), mesh), I.x.get(), I.topology.cellOffsets.get(), I.topology.cellVertices.get(), out,
                      I.stream);
  SINEW_CUDA(cudaGetLastError());
}

void* CudaEngine::nativeStream() const { return impl_->stream; }

void CudaEngine::synchronize() { SINEW_CUDA(cudaStreamSynchronize(impl_->stream)); }

std::vector<std::vector<Vec3>> CudaEngine::contourSegments(const Vec3& normal, float offset) {
  Impl& I = *impl_;
  return I.contour.segments(I.sim.store(), I.topology, I.x.get(), normal, offset, I.stream);
}

std::string CudaEngine::device() const { return impl_->device; }

std::size_t CudaEngine::deviceBytes() const {
  const Impl& I = *impl_;
  return I.topology.bytes() + I.stepBlocks.bytes() + I.density.bytes() + I.massFloor.bytes() + I.elevation.bytes() +
         I.area.bytes() + I.mass.bytes() + I.x.bytes() + I.prev.bytes() + I.force.bytes() + I.normal.bytes() +
         I.centre.bytes() + I.reference.bytes() + I.imageTexture.bytes() + I.profiles.bytes() + I.gradient.bytes() +
         I.contour.bytes() + I.implicitA.bytes() + I.implicitB.bytes() + I.implicitOff.bytes() + I.implicitC.bytes() +
         I.implicitVel.bytes() + I.implicitRhs.bytes() + I.implicitR.bytes() + I.implicitZ.bytes() + I.implicitP.bytes() +
         I.implicitAp.bytes() + I.collision.bytes() + I.thirdPositions.bytes() + I.sampledError.bytes() + I.contactLinks.bytes() + I.radial.bytes() +
         I.attachments.bytes();
}

}  // namespace sinew::cuda

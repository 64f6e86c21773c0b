// Launchers of the CUDA kernels (defined in the .cu files) and the plain structs they take; no
// device code here, so host C++ (the engine) includes it.
#pragma once

#include "sinew/cuda/device_force.h"  // MeshView, ParamView

#include <cuda_runtime.h>

#include <cstddef>

namespace sinew::collision {
struct Node;
struct Box;
struct Tri;
struct P3;
struct ContactSettings;
struct HoldPlane;
struct ContactPlane;
}  // namespace sinew::collision
namespace sinew::trianglebvh {
struct Node;
struct TangentPlane;
}  // namespace sinew::trianglebvh
namespace sinew {
struct WeightedDistance;
}  // namespace sinew

namespace sinew::cuda {

struct ContactPlanes;  // contact_planes.h

// A volume in linear device memory with the host Volume's world-to-index transform.
struct VolumeView {
  int sx, sy, sz;
  float m[9];  // world -> continuous index, row-major
  float3 origin;
};

// The per-vertex forces that run fused in one kernel (the prefix of the scene's force list made of
// them); k0..k2 are parameter columns (smoothing: elevation_term; gradient: epsilon, search_depth,
// sample_spacing).
struct FusedTerm {
  enum Kind { Smoothing, ShapePrior, Gradient } kind;
  ParamView params;
  int k0 = 0, k1 = 0, k2 = 0;
};
struct FusedTerms {
  FusedTerm terms[4];
  int count = 0;
  const float4* reference = nullptr;
  VolumeView gradientVolume{};
  const float3* gradient = nullptr;
  const float3* plus = nullptr;  // when set, added after the terms: a force an earlier pass wrote
};
inline bool hasGradientTerm(const FusedTerms& t) {
  for (int i = 0; i < t.count; ++i)
    if (t.terms[i].kind == FusedTerm::Gradient) return true;
  return false;
}

// The geometry the store requires (cell centres, normals, elevations, areas, masses). cellSpans:
// null, or per vertex its three cells' first entries in m.cellVertices and their sizes
// (kCellSpanBits bits each, in w), which scenes below geometryReadsCellSpans read instead of the
// offsets.
constexpr int kCellSpanBits = 10;
bool geometryReadsCellSpans(int vertices);
void launchGeometry(const MeshView& m, const int4* cellSpans, cudaStream_t s);
// Writes (not adds) the fused terms' sum to m.force, zero when no term is active.
void launchFusedForces(const MeshView& m, const FusedTerms& t, cudaStream_t s);
void launchSmoothing(const MeshView& m, ParamView p, int elevationTerm, cudaStream_t s);
// reference: (eps1, eps2, sin phi, cos phi) per vertex.
void launchShapePrior(const MeshView& m, ParamView p, const float4* reference, cudaStream_t s);
void launchGradient(const MeshView& m, ParamView p, int kEps, int kDepth, int kStep, VolumeView volume,
                    const float3* gradient, cudaStream_t s);
// The target image's values mapped to [0, 1] in 16-bit steps for its texture (image_kernels.cu).
// scratch: 2 + 2 * kNormaliseParts floats (the range, then the reduction's parts).
constexpr int kNormaliseParts = 1024;
void launchNormalise16(const float* values, size_t n, float* scratch, unsigned short* out, cudaStream_t s);
// The profile force (profile_kernels.cu). image: the target image as a texture
// (DeviceImageTexture); maxReach: the largest floor(search_depth / spacing) over the structures.
// then: when not null, the step's damped Verlet move follows (the profile being the step's last
// force), in the same pass where the kernel allows.
struct VerletMove {
  float dt, keep;  // keep: 1 - damping
};
void launchProfile(const MeshView& m, ParamView p, int kDepth, VolumeView volume, cudaTextureObject_t image,
                   const float* profiles, int inside, int outside, float spacing, int maxReach, const VerletMove* then,
                   cudaStream_t s);
// The fused terms and the move in one pass, when no other force follows them: as
// launchProfileAfterTerms, the new positions are written over m.prev and the caller swaps m.x and
// m.prev afterwards. The lean geometry (no gradient term): with m.normal and m.mass null (and
// launchGeometry run with them null), each vertex's normal and mass are computed in the pass from
// its neighbours and m.area. With m.force null the forces are not written.
void launchFusedForcesAndMove(const MeshView& m, const FusedTerms& t, const VerletMove& move, cudaStream_t s);
// The same step with the geometry in its pass (the lean geometry only: no gradient term, no other
// pass's term (FusedTerms::plus null), m.mass null; launchGeometry is not needed before it;
// block_step_kernels.cu). A block takes kStepBlock
// consecutive vertices and reads, once each, the positions its step needs (its own, its
// neighbours' beyond it, and the vertices of their cells) into shared memory; the cell centres,
// areas and elevations then stay there. StepBlocks holds each block's connectivity as indices into
// its own shared arrays (DeviceStepBlocks builds it once per level).
constexpr int kStepBlock = 256;
// Where each of a block's shared arrays begins in the one-pass step, in 4-byte words from the start
// of its dynamic shared memory: the own vertices' references, the block's positions and cell
// centres, the own previous positions, the geometry entries with their areas and elevations, the
// own structures, and the 16-bit cell arrays. Every region starts on 16 bytes (the kernel copies in
// 16-byte pieces), and the arrays copied as the 16-byte span that holds them get 16 bytes more.
// Laid out for the largest block's counts, so that the offsets are the launch's constants and take
// no registers.
struct StepBlockLayout {
  int pos = 0, centre = 0, previous = 0, geometry = 0, area = 0, elevation = 0, mesh = 0, cellEnd = 0, cellSlots = 0;
  int words = 0;  // the whole
};
inline StepBlockLayout stepBlockLayout(int positions, int cells, int geometries, int cellSlots) {
  StepBlockLayout l;
  int at = 4 * kStepBlock;  // the references
  const auto take = [&at](int& region, int words) { region = at, at += (words + 3) / 4 * 4; };
  take(l.pos, 3 * positions);
  take(l.centre, 3 * cells);
  take(l.previous, 3 * kStepBlock);
  take(l.geometry, 3 * geometries + 4);
  take(l.area, geometries);
  take(l.elevation, geometries);
  take(l.mesh, kStepBlock);
  take(l.cellEnd, (cells + 1) / 2 + 4);
  take(l.cellSlots, (cellSlots + 1) / 2 + 4);
  l.words = at;
  return l;
}
// The 4-byte words that the one-pass step's 16-byte-piece copy (copySpan) writes for the bytes
// [first, first + bytes) of an array (first counted from a 16-byte-aligned address): the layout's
// regions must hold them, and tst_step_blocks checks that every block's do.
__host__ __device__ inline int spanCopyWords(long long first, long long bytes) {
  return int((((first + bytes + 15) & ~15ll) - (first & ~15ll)) / 4);
}
struct StepBlocks {
  // Per block, and one more for the ends: where its entries of the arrays below begin (x: vertices,
  // y: geometry, z: cellEnd, w: cellSlots).
  const int4* start = nullptr;
  // A block's positions are its own vertices (slot i: vertex first + i), then these vertices:
  // its geometry's vertices outside it, then the other vertices its cells and their neighbours need.
  const int* vertices = nullptr;
  // Per vertex whose area and elevation the block computes (its own, then those outside it, in
  // slot order): for each of its neighbours j, the neighbour's slot | its cell j's index << 16.
  const int3* geometry = nullptr;
  const unsigned short* cellEnd = nullptr;    // per block cell: the end of its slots in cellSlots
  const unsigned short* cellSlots = nullptr;  // a cell's vertices' slots, in the cell's order
  StepBlockLayout layout;                     // the shared arrays (4 * layout.words bytes)
};
void launchStepInBlocks(const MeshView& m, const StepBlocks& blocks, const FusedTerms& t, const VerletMove& move,
                        cudaStream_t s);
// Whether launchProfileAfterTerms can run for this layout and size: the register kernels, below the
// size where the move leaves the profile's pass.
bool profileTakesTerms(int vertices, int inside, int outside, int maxReach);
// The fused terms (without a gradient term), the profile and the move in one pass: each vertex's
// force is the terms' sum plus its profile term, written to m.force, and its new position is
// written over m.prev (verletMoveAside), so that the pass's other vertices still read this step's
// positions; the caller swaps m.x and m.prev afterwards. One launch instead of two.
// planes (or null): the collision's contact planes between full searches, added after the profile's
// term (contact_planes.h; the collision then the step's last force). Their hold follows after the
// swap (launchCollisionHold), or, with planes->heldPrevious, runs in the pass: the previous
// positions then go to that third buffer, which becomes m.prev after the swap.
void launchProfileAfterTerms(const MeshView& m, const FusedTerms& terms, ParamView p, int kDepth, VolumeView volume,
                             cudaTextureObject_t image, const float* profiles, int inside, float spacing, int maxReach,
                             const VerletMove& move, const ContactPlanes* planes, cudaStream_t s);
// For larger scenes, where the move leaves the profile's pass (profileTakesTerms false but the
// register layout): the profile's term alone written to m.force (zero where it is off), for
// launchFusedForcesAndMove with FusedTerms::plus = m.force to add after the terms. The separate
// move's pass goes. planes (or null): the collision's contact planes between full searches, added
// after the profile's term (their hold planes written for launchCollisionHold after the move).
bool profileGoesFirst(int vertices, int inside, int outside, int maxReach);
void launchProfileFirst(const MeshView& m, ParamView p, int kDepth, VolumeView volume, cudaTextureObject_t image,
                        const float* profiles, int inside, float spacing, int maxReach, const ContactPlanes* planes,
                        cudaStream_t s);
// The attraction_points force. points: every placed point; pointMesh: the structure of each;
// pointKind: kAttractPoint, kIncludePoint or kExcludePoint; keys, windings: one of each per point;
// constraints: whether any point is an include or exclude point (m.cellCentre is then required).
constexpr int kAttractPoint = 0, kIncludePoint = 1, kExcludePoint = 2;
void launchAttraction(const MeshView& m, ParamView p, int kRing, int kMargin, const float3* points, const int* pointMesh,
                      const int* pointKind, const int* meshBegin, const int* meshEnd, int pointCount,
                      unsigned long long* keys, float* windings, bool constraints, cudaStream_t s);
void launchVerlet(const MeshView& m, float dt, float keep, cudaStream_t s);
// The affine regularisation (affine_kernels.cu): adds share * (closest affine field of imageForce,
// per structure) + (1 - share) * imageForce to m.force. parts: blocks per structure, each summing
// kAffineChunk vertices (at least the largest structure's vertices / kAffineChunk); moments: 22
// doubles per structure and part; coefficients: 12 per structure.
constexpr int kAffineChunk = 4096;
void launchAffineRegularisation(const MeshView& m, const float3* imageForce, const int* meshBegin, const int* meshEnd,
                                int meshes, int parts, double* moments, double* coefficients, float share,
                                cudaStream_t s);
// Implicit Euler (implicit_kernels.cu): per structure, the weights of the forces whose Jacobian is
// a pull toward the neighbours (smoothing, shape prior) and along the normal (gradient, profile).
struct ImplicitTerms {
  const float* meshPull = nullptr;
  const float* meshNormalPull = nullptr;
  const float* contactPull = nullptr;  // per vertex (collisions: self block -contactPull I), or null
  const float* springPull = nullptr;   // per vertex (deforming contacts: self block -springPull I), or null
  // Per vertex (the radial force), or null: self block -radialPull [s (I - u u^T) + u u^T], s the
  // radialSlack, u the radialDirection.
  const float* radialPull = nullptr;
  const float* radialSlack = nullptr;
  const float3* radialDirection = nullptr;
};
// Work arrays, one entry per vertex, and the solve's scalars.
constexpr int kImplicitScalars = 8;
struct ImplicitWork {
  float *a = nullptr, *b = nullptr, *off = nullptr, *c = nullptr;  // c: the radial force's u u^T weight
  float3 *vel = nullptr, *rhs = nullptr, *r = nullptr, *z = nullptr, *p = nullptr, *ap = nullptr;
  double* scalars = nullptr;
};
void launchImplicitEuler(const MeshView& m, const ImplicitTerms& t, const ImplicitWork& w, float dt, float kappa,
                         double tolerance, int maxIterations, cudaStream_t s);
// fine[i] = sum_k weight[k] coarse[index[k]] (level change on the device).
// One structure's vertex and cell ranges (global indices), for drawing.
struct DrawRange {
  int vertexBegin = 0, vertexEnd = 0, cellBegin = 0, cellEnd = 0;
};
// Tessellation points (vertices, then cell centres) as packed xyz floats.
void launchSurfacePoints(const DrawRange& r, const float3* x, const int* offsets, const int* cellVertices, float* out,
                         cudaStream_t s);
// Contour segments (pairs of points) where every structure's tessellation crosses dot(n, x) = d.
// Structure m's segments are written from out[2 * segmentBase[m]] on and counted in counts[m];
// those beyond its capacity (segmentBase[m + 1] - segmentBase[m]) are counted but not written.
void launchContour(int cells, const float3* x, const int* offsets, const int* cellVertices, const int* meshOf,
                   float3 n, float d, const int* segmentBase, float3* out, int* counts, cudaStream_t s);

// Multi-resolution forces (multires_kernels.cu): to[i] = from[index[i]]; fine[i] += scale * (P coarse)[i].
void launchGather(const int* index, int count, const float3* from, float3* to, cudaStream_t s);
void launchProlongAdd(const int* rows, const int* index, const float* weight, int count, const float3* coarse,
                      float3* fine, float scale, cudaStream_t s);

// The collision refit's nodes by how it computes their boxes (collision_kernels.cu nodeBoxes), all
// from their vertices' boxes: at most kThreadNode vertices a thread each, at most kWarpNode a warp
// each, the larger ones a block each.
constexpr int kThreadNode = 8, kWarpNode = 512, kClimbFrom = 131072;
struct NodeLists {
  const int* threadNodes = nullptr;
  const int* warpNodes = nullptr;
  const int* blockNodes = nullptr;
  int threadCount = 0, warpCount = 0, blockCount = 0;
};
// Collisions (collision_kernels.cu): the hierarchies of core/collision_tree.h in device memory.
// stiffness (per vertex, may be null): each vertex's summed contact pull, for implicit Euler.
struct CollisionDevice {
  const collision::Node* nodes = nullptr;
  collision::Box* boxes = nullptr;
  const collision::Tri* tris = nullptr;
  const int* order = nullptr;
  const int* roots = nullptr;
  // The refit (collision_kernels.cu): from kClimbFrom vertices up the climb from the leaves,
  // below it each vertex's box then every node's at once.
  bool climb = false;
  const int* leaves = nullptr;
  int* visits = nullptr;  // per node, the climb's arrival counters
  collision::Box* vertexBoxes = nullptr;  // per vertex in tree order
  NodeLists lists;
  float* stiffness = nullptr;
  float* depth = nullptr;  // per vertex, the last penetration (collision::contactResponse)
  int* hint = nullptr;     // per vertex, the last nearest contact leaf
  float* slack = nullptr;  // per vertex, its clearance beyond the margin (collision::clearOfContacts)
  float* moved = nullptr;  // per vertex, how far it moved since the last full search
  float3* last = nullptr;  // the positions the last full search saw
  unsigned* motion = nullptr;  // the step's largest move (a float's bits: atomicMax orders them)
  const unsigned char* exempt = nullptr;  // pairs left out (meshes x meshes), or null
  const float* share = nullptr;           // collision::shareOf's table (meshes x meshes), or null
  float* lastDepth = nullptr;  // per vertex, depth as a full search begins (collision::shareAt); null without share
  collision::HoldPlane* hold = nullptr;  // per vertex, the plane the hold moves it out of after the step
  // per vertex, its deepest contact at the last full search (valid where contactShare >= 0)
  collision::ContactPlane* contact = nullptr;
  float* contactShare = nullptr;  // per vertex, contact's share alone: most vertices have none, and read only this
  float3* force = nullptr;  // per vertex, the response's force, apart from m.force (launchCollisionRespond)
  // Per vertex, the reaction's sums on it and a flag (ReactionSums, contact_planes.h); null: none.
  unsigned long long* reaction = nullptr;
  int meshes = 0, nodeCount = 0, leafCount = 0;
};
// Deforming contacts (collision_kernels.cu; core/contact_links.h): adds alpha m_i (x_j + o_i - x_i)
// to m.force for each vertex i with a partner j; stiffness (may be null) gets alpha m_i, or 0.
void launchContactSprings(const MeshView& m, ParamView p, const int* partner, const float3* offset, float* stiffness,
                          cudaStream_t s);
// The collision force's full search in two launches, which write nothing of m, so that they may
// run beside the step's other kernels. Refits the hierarchies: reads m.x and, where c.climb,
// m.cellCentre (below kClimbFrom vertices it computes the centres it needs, so it need not follow
// the geometry kernel).
void launchCollisionRefit(const MeshView& m, const CollisionDevice& c, cudaStream_t s);
// After the refit and the geometry: writes the contact response to c.force (reads m.x, m.prev,
// m.normal, m.mass, m.cellCentre) and, where settings.reaction > 0, sums the reaction into
// c.reaction (launchCollisionReaction's sums, without a launch of their own). every: a full search
// every this many steps (its search radius, collision::fullSearchBound).
void launchCollisionRespond(const MeshView& m, ParamView p, const CollisionDevice& c,
                            const collision::ContactSettings& settings, int every, cudaStream_t s);
// Where the collision reacts (ReactionSums, contact_planes.h): each vertex with a contact plane
// sums its push on the other surface's contact triangle (collision::reactionPush). Reads only m.x
// and the planes (the normals and cell centres computed as the geometry pass computes them), so
// between full searches it runs beside that pass (a full search's response sums them itself).
// launchCollisionAdd or launchCollisionMove (or the profile's pass with the contact planes) then
// add the sums times the vertex's mass, and set them back to 0.
struct ReactionSums;
void launchCollisionReaction(const MeshView& m, const ReactionSums& r, cudaStream_t s);
// Adds c.force (launchCollisionRespond's) and the reaction (where c.reaction) to m.force.
void launchCollisionAdd(const MeshView& m, const CollisionDevice& c, cudaStream_t s);
// launchCollisionAdd, launchVerlet and (hold: launchCollisionHold) in one pass, the same
// arithmetic: for a step whose last force is the collision's and whose move follows directly.
void launchCollisionMove(const MeshView& m, const CollisionDevice& c, const VerletMove& move,
                         const collision::ContactSettings& settings, cudaStream_t s);
// A step between full searches (collision::contactResponse), which the engine schedules itself:
// instead of the refit and the response, each vertex's contact plane writes its response to `out`,
// and its depth, hold and stiffness as launchCollisionRespond would (reads
// m.x, m.prev, m.normal, m.mass, m.cellCentre). With out = c.force, launchCollisionAdd or
// launchCollisionMove and launchCollisionHold follow as after the response. Such a step leaves the
// largest move alone (only full searches set it, and their step's end resets it).
void launchCollisionPlanes(const MeshView& m, const ContactPlanes& planes, float3* out, cudaStream_t s);
// After the step's move: each vertex below its hold plane (c.hold, written by
// launchCollisionRespond when settings.hold >= 0) moves out along its normal onto it
// (CollisionForce::constrain). Every launchCollisionRespond with settings.hold >= 0 must be followed
// by it or by launchCollisionMove with hold true: they also end the collision's step (its motion).
void launchCollisionHold(const MeshView& m, const CollisionDevice& c, const collision::ContactSettings& settings,
                         cudaStream_t s);

// The radial force (radial_kernels.cu; device_radial.h): the medial surfaces of the structures
// laid out globally. Surface vertex v: its medial points surfaceMedial[surfaceOffsets[v] ..
// surfaceOffsets[v + 1]) with surfaceWeight, and its radius r_v. Medial vertex j: its structure and
// its surface vertices medialVertex[medialOffsets[j] .. medialOffsets[j + 1]) with medialWeight,
// cut into chunks of at most kRadialChunk entries (at least one per medial vertex, empty where it
// has none): chunk c holds entries chunkBegin[c] .. chunkBegin[c + 1] of medial vertex chunkRow[c],
// whose chunks are rowChunks[j] .. rowChunks[j + 1].
constexpr int kRadialChunk = 256;
struct RadialDevice {
  const int* surfaceOffsets = nullptr;
  const int* surfaceMedial = nullptr;
  const float* surfaceWeight = nullptr;
  const float* radius = nullptr;
  const int* medialMesh = nullptr;
  const int* medialOffsets = nullptr;
  const int* medialVertex = nullptr;
  const float* medialWeight = nullptr;
  const int* chunkBegin = nullptr;
  const int* chunkRow = nullptr;
  const int* rowChunks = nullptr;
  float4* partial = nullptr;      // per chunk: its reaction and stiffness
  unsigned* arrivals = nullptr;   // per medial vertex: its chunks done in this relaxation (0 between)
  int medialCount = 0, chunkCount = 0;
};
// q[j] = the weighted mean of x_i - r_i n_i over its surface vertices, for the medial vertices of
// the structures with fresh[structure] != 0 (others untouched; needs m.normal).
void launchRadialVotes(const MeshView& m, const RadialDevice& r, const int* fresh, float3* q, cudaStream_t s);
// One Jacobi relaxation of the medial vertices of structures whose alpha is positive, from qIn to
// qOut (the others copied).
void launchRadialRelax(const MeshView& m, ParamView p, const RadialDevice& r, const float3* qIn, float3* qOut,
                       cudaStream_t s);
// Adds alpha m_i (1 - r_i / |P_i P_i_perp|) P_i P_i_perp to m.force, the medial points from q; copies
// q into home when home is not null. With pull not null (implicit Euler), also writes each vertex's
// Jacobian terms (ImplicitTerms' radial arrays; pull 0 where the force does not act).
void launchRadialApply(const MeshView& m, ParamView p, const RadialDevice& r, const float3* q, float3* home,
                       float* pull, float* slack, float3* direction, cudaStream_t s);

// Attachments (attachment_kernels.cu; core/attachments.h): the level's constraints, applied around
// the integrator as Simulation::step does. Constrained vertices are distinct (a vertex is merged,
// fixed or attached once); attachedInOrder: some attached vertex follows another, so they are
// placed one after the other.
struct AttachmentDevice {
  const int* mergedA = nullptr;
  const int* mergedB = nullptr;
  const float3* mergedOffset = nullptr;
  float* mergedShare = nullptr;  // a's share of the pair's mass, from the last share
  const int* fixedVertex = nullptr;
  const float3* fixedAt = nullptr;
  const int* attachedVertex = nullptr;
  const int* attachedOffsets = nullptr;
  const int* attachedSource = nullptr;
  const float* attachedWeight = nullptr;
  const float3* attachedOffset = nullptr;
  int mergedCount = 0, fixedCount = 0, attachedCount = 0;
  bool attachedInOrder = false;
};
// Before the integrator: merged pairs share their summed force by mass, fixed and attached vertices
// get none (needs m.mass).
void launchAttachmentShare(const MeshView& m, const AttachmentDevice& a, cudaStream_t s);
// After it: merged pairs at their offset about their centre of mass, fixed vertices back, attached
// ones onto their surface (positions and previous positions).
void launchAttachmentProject(const MeshView& m, const AttachmentDevice& a, cudaStream_t s);

// The timeline's sampled error (error_kernels.cu; core/sampled_error.h): device copies of its
// hierarchies and samples, and where the distances go.
struct SampledErrorDevice {
  trianglebvh::Node* meshNodes = nullptr;  // refitted here
  const int* parents = nullptr;            // per mesh node, -1 at roots
  const int* leaves = nullptr;
  const int3* triangles = nullptr;         // point indices, in leaf order
  const int* triangleStructure = nullptr;
  const int* meshRoots = nullptr;
  collision::P3* points = nullptr;         // vertices, then cell centres
  collision::P3* corners = nullptr;
  int* visits = nullptr;
  const trianglebvh::Node* truthNodes = nullptr;
  const collision::P3* truthCorners = nullptr;
  const int* truthRoots = nullptr;         // per structure, -1 without a truth
  const float3* samples = nullptr;         // the truths' samples
  const float* sampleAreas = nullptr;
  const int* samplePatch = nullptr;        // each sample's patch
  const collision::P3* patchCentres = nullptr;
  const int* patchStructure = nullptr;
  trianglebvh::TangentPlane* planes = nullptr;  // per patch
  WeightedDistance* toTruth = nullptr;     // samplesPerTriangle per triangle
  WeightedDistance* fromTruth = nullptr;   // one per sample
  int meshNodeCount = 0, leafCount = 0, triangleCount = 0, sampleCount = 0, patchCount = 0, samplesPerTriangle = 4;
};
void launchSampledError(const MeshView& m, const SampledErrorDevice& e, cudaStream_t s);
// out[k]: the exact distance from points[k] to the mesh under roots[k] (the exact evaluation's).
void launchClosestDistances(const trianglebvh::Node* nodes, const collision::P3* corners, const collision::P3* points,
                            const int* roots, int count, float* out, cudaStream_t s);

void launchProlong(const int* rowOffsets, const int* index, const float* weight, int rows, const float3* coarse,
                   float3* fine, cudaStream_t s);

}  // namespace sinew::cuda

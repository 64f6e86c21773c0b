// Implicit Euler on the device: the same system as the CPU integrator (implicit_euler.cpp),
//   (M (1 + dt kappa) - dt^2 K) v' = M v + dt f,   x' = x + dt v',
// for the built-in forces' Jacobians: per vertex K's self block is -pull I - normalPull n n^T and
// each neighbour block pull/3 I (pull: the structure's smoothing + shape prior weights; normalPull:
// its gradient + profile weights), with the collisions', contacts' and radial force's per-vertex
// terms added to the self block. Conjugate gradients with the 3x3 diagonal blocks inverted in
// closed form; the iteration count is fixed in the captured graph, and once converged the
// remaining iterations return at once (a device flag), so no step waits for the host.
#include "device_math.cuh"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;
unsigned blocks(int n) { return (n + kThreads - 1) / kThreads; }

// Scalars of the solve, in device memory.
enum Slot { kRz, kPAp, kRr, kBb, kRzNext, kBeta, kDone, kNonFinite, kSlots };
static_assert(kSlots == kImplicitScalars, "ImplicitWork::scalars holds kImplicitScalars doubles");

__device__ void addToSlot(double value, double* slot) {
  __shared__ double partial[kThreads / 32];
  for (int offset = 16; offset > 0; offset /= 2) value += __shfl_down_sync(0xffffffffu, value, offset);
  if (threadIdx.x % 32 == 0) partial[threadIdx.x / 32] = value;
  __syncthreads();
  if (threadIdx.x == 0) {
    double s = 0.0;
    for (unsigned w = 0; w < blockDim.x / 32; ++w) s += partial[w];
    atomicAdd(slot, s);
  }
  __syncthreads();  // the next sum reuses `partial`
}

struct System {
  const float* a;      // diagonal block a I + b n n^T (+ c u u^T)
  const float* b;
  const float* off;    // neighbour blocks -off I
  const float3* n;
  const int3* nb;
  const float* c;      // the radial force's term, or null
  const float3* u;
};

__device__ float3 multiply(const System& s, const float3* u, int v) {
  const float3 uv = u[v];
  const int3 k = s.nb[v];
  float3 y = s.a[v] * uv - s.off[v] * (u[k.x] + u[k.y] + u[k.z]);
  if (s.n) y = y + (s.b[v] * dot(s.n[v], uv)) * s.n[v];
  if (s.c) y = y + (s.c[v] * dot(s.u[v], uv)) * s.u[v];
  return y;
}

// (a I + b n n^T)^-1 r = (r - b / (a + b) (n . r) n) / a, n of unit length.
__device__ float3 solveNormalBlock(const System& s, float3 r, int v) {
  if (!s.n) return (1.0f / s.a[v]) * r;
  const float3 n = s.n[v];
  return (1.0f / s.a[v]) * (r - (s.b[v] / (s.a[v] + s.b[v]) * dot(n, r)) * n);
}

// The diagonal block's inverse; with the radial term by Sherman-Morrison:
// (A + c u u^T)^-1 r = A^-1 r - c (u . A^-1 r) / (1 + c u . A^-1 u) A^-1 u.
__device__ float3 precondition(const System& s, float3 r, int v) {
  const float3 ar = solveNormalBlock(s, r, v);
  if (!s.c || !(s.c[v] > 0.0f)) return ar;
  const float3 u = s.u[v], au = solveNormalBlock(s, u, v);
  return ar - (s.c[v] * dot(u, ar) / (1.0f + s.c[v] * dot(u, au))) * au;
}

__global__ void setup(MeshView m, ImplicitTerms t, float h, float kappa, float* a, float* b, float* off, float* c,
                      float3* vel, float3* rhs) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const int mesh = m.meshOf[v];
  const float pull = t.meshPull[mesh], normalPull = t.meshNormalPull[mesh];
  a[v] = m.mass[v] * (1.0f + h * kappa) + h * h * pull;
  if (t.contactPull) a[v] += h * h * t.contactPull[v];
  if (t.springPull) a[v] += h * h * t.springPull[v];
  if (t.radialPull) {
    const float k = t.radialPull[v], slack = t.radialSlack[v];
    a[v] += h * h * (k * slack);
    c[v] = h * h * (k * (1.0f - slack));
  }
  b[v] = h * h * normalPull;
  off[v] = h * h * pull / 3.0f;
  const float3 velocity = (m.x[v] - m.prev[v]) / h;
  vel[v] = velocity;
  rhs[v] = m.mass[v] * velocity + h * m.force[v];
}

__global__ void residual(int count, System s, const float3* vel, const float3* rhs, float3* r, float3* z, float3* p,
                         double* scalars) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double rz = 0.0, rr = 0.0, bb = 0.0;
  if (v < count) {
    const float3 rv = rhs[v] - multiply(s, vel, v), zv = precondition(s, rv, v);
    r[v] = rv, z[v] = zv, p[v] = zv;
    rz = dot(rv, zv), rr = dot(rv, rv), bb = dot(rhs[v], rhs[v]);
  }
  addToSlot(rz, &scalars[kRz]);
  addToSlot(rr, &scalars[kRr]);
  addToSlot(bb, &scalars[kBb]);
}

// Converged (or nothing to do) before the first iteration?
__global__ void start(double* scalars, double tolerance) {
  if (!isfinite(scalars[kRr]) || !isfinite(scalars[kBb])) {
    // A non-finite force: the step becomes non-finite (advance), so the guard sees it.
    scalars[kNonFinite] = 1.0;
    scalars[kDone] = 1.0;
  }
  if (!(scalars[kRr] > tolerance * tolerance * scalars[kBb])) scalars[kDone] = 1.0;
  scalars[kRr] = 0.0;
}

__global__ void cgMultiply(int count, System s, const float3* p, float3* ap, double* scalars) {
  if (scalars[kDone] != 0.0) return;
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double pap = 0.0;
  if (v < count) {
    const float3 y = multiply(s, p, v);
    ap[v] = y;
    pap = dot(p[v], y);
  }
  addToSlot(pap, &scalars[kPAp]);
}

__global__ void cgUpdate(int count, System s, const float3* p, const float3* ap, float3* vel, float3* r, float3* z,
                         double* scalars) {
  if (scalars[kDone] != 0.0 || !(scalars[kPAp] > 0.0)) return;
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  double rz = 0.0, rr = 0.0;
  if (v < count) {
    const float alpha = static_cast<float>(scalars[kRz] / scalars[kPAp]);
    vel[v] = vel[v] + alpha * p[v];
    const float3 rv = r[v] - alpha * ap[v], zv = precondition(s, rv, v);
    r[v] = rv, z[v] = zv;
    rz = dot(rv, zv), rr = dot(rv, rv);
  }
  addToSlot(rz, &scalars[kRzNext]);
  addToSlot(rr, &scalars[kRr]);
}

__global__ void cgFinish(double* scalars, double tolerance) {
  if (scalars[kDone] != 0.0) return;
  if (!(scalars[kPAp] > 0.0)) {  // not positive definite: keep the last iterate
    scalars[kDone] = 1.0;
    return;
  }
  scalars[kBeta] = scalars[kRzNext] / scalars[kRz];
  scalars[kRz] = scalars[kRzNext];
  if (!(scalars[kRr] > tolerance * tolerance * scalars[kBb])) scalars[kDone] = 1.0;
  scalars[kRzNext] = scalars[kPAp] = scalars[kRr] = 0.0;
}

__global__ void cgDirection(int count, const float3* z, float3* p, const double* scalars) {
  if (scalars[kDone] != 0.0) return;
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v < count) p[v] = z[v] + static_cast<float>(scalars[kBeta]) * p[v];
}

__global__ void advance(MeshView m, float h, const float3* vel, const double* scalars) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const float3 current = m.x[v];
  m.prev[v] = current;
  const float nan = __int_as_float(0x7fc00000);
  m.x[v] = scalars[kNonFinite] != 0.0 ? make_float3(nan, nan, nan) : current + h * vel[v];
}
}  // namespace

void launchImplicitEuler(const MeshView& m, const ImplicitTerms& t, const ImplicitWork& w, float dt, float kappa,
                         double tolerance, int maxIterations, cudaStream_t s) {
  const int n = m.vertices;
  cudaMemsetAsync(w.scalars, 0, kSlots * sizeof(double), s);
  setup<<<blocks(n), kThreads, 0, s>>>(m, t, dt, kappa, w.a, w.b, w.off, w.c, w.vel, w.rhs);
  const System sys{w.a, w.b, w.off, m.normal, m.neighbours, t.radialPull ? w.c : nullptr, t.radialDirection};
  residual<<<blocks(n), kThreads, 0, s>>>(n, sys, w.vel, w.rhs, w.r, w.z, w.p, w.scalars);
  start<<<1, 1, 0, s>>>(w.scalars, tolerance);
  for (int it = 0; it < maxIterations; ++it) {
    cgMultiply<<<blocks(n), kThreads, 0, s>>>(n, sys, w.p, w.ap, w.scalars);
    cgUpdate<<<blocks(n), kThreads, 0, s>>>(n, sys, w.p, w.ap, w.vel, w.r, w.z, w.scalars);
    cgFinish<<<1, 1, 0, s>>>(w.scalars, tolerance);
    cgDirection<<<blocks(n), kThreads, 0, s>>>(n, w.z, w.p, w.scalars);
  }
  advance<<<blocks(n), kThreads, 0, s>>>(m, dt, w.vel, w.scalars);
}

}  // namespace sinew::cuda

// The affine regularisation of the image forces (paper 001 section 3) on the device, as
// Simulation::regulariseImageForces on the CPU: per structure the least-squares affine field of the
// image forces g at the positions x (normal equations in double: blocks of kAffineChunk vertices sum
// their share, the solve adds the blocks' sums in order, so runs repeat exactly), then
// f += share * (A x + t) + (1 - share) * g.
#include "kernels.h"

namespace sinew::cuda {

namespace {
constexpr int kMomentThreads = 128;
// Per structure: the upper triangle of sum h h^T (10 values, h = (x, y, z, 1)) and sum h g^T (12).
constexpr int kMoments = 22;

// Block (part, mesh) sums vertices [begin + part * kAffineChunk, ...) of its structure.
__global__ void affineMoments(const float3* x, const float3* g, const int* meshBegin, const int* meshEnd,
                              double* moments) {
  __shared__ double partial[kMoments][kMomentThreads];
  const int mesh = blockIdx.y;
  const int begin = meshBegin[mesh] + blockIdx.x * kAffineChunk;
  const int end = min(meshEnd[mesh], begin + kAffineChunk);
  double acc[kMoments];
  for (int k = 0; k < kMoments; ++k) acc[k] = 0.0;
  for (int v = begin + threadIdx.x; v < end; v += kMomentThreads) {
    const double h[4] = {x[v].x, x[v].y, x[v].z, 1.0};
    const double f[3] = {g[v].x, g[v].y, g[v].z};
    int k = 0;
    for (int i = 0; i < 4; ++i)
      for (int j = i; j < 4; ++j) acc[k++] += h[i] * h[j];
    for (int i = 0; i < 4; ++i)
      for (int j = 0; j < 3; ++j) acc[k++] += h[i] * f[j];
  }
  for (int k = 0; k < kMoments; ++k) partial[k][threadIdx.x] = acc[k];
  __syncthreads();
  for (int stride = kMomentThreads / 2; stride > 0; stride /= 2) {
    if (threadIdx.x < stride)
      for (int k = 0; k < kMoments; ++k) partial[k][threadIdx.x] += partial[k][threadIdx.x + stride];
    __syncthreads();
  }
  if (threadIdx.x < kMoments) moments[(mesh * gridDim.x + blockIdx.x) * kMoments + threadIdx.x] = partial[threadIdx.x][0];
}

// One thread per structure: solves the 4x4 normal equations for the 4x3 coefficients by Gaussian
// elimination with partial pivoting; a singular system leaves NaN, and the blend then keeps g.
__global__ void affineSolve(const double* moments, int parts, double* coefficients, int meshes) {
  const int mesh = blockIdx.x * blockDim.x + threadIdx.x;
  if (mesh >= meshes) return;
  double m[kMoments];
  for (int k = 0; k < kMoments; ++k) m[k] = 0.0;
  for (int part = 0; part < parts; ++part)  // in order: the same sum on every run
    for (int k = 0; k < kMoments; ++k) m[k] += moments[(mesh * parts + part) * kMoments + k];
  double a[4][7];
  int k = 0;
  for (int i = 0; i < 4; ++i)
    for (int j = i; j < 4; ++j) a[i][j] = a[j][i] = m[k++];
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) a[i][4 + j] = m[k++];
  for (int c = 0; c < 4; ++c) {
    int pivot = c;
    for (int r = c + 1; r < 4; ++r)
      if (fabs(a[r][c]) > fabs(a[pivot][c])) pivot = r;
    for (int j = 0; j < 7; ++j) {
      const double t = a[c][j];
      a[c][j] = a[pivot][j];
      a[pivot][j] = t;
    }
    const double d = a[c][c];
    for (int r = 0; r < 4; ++r) {
      if (r == c) continue;
      const double f = d != 0.0 ? a[r][c] / d : nan("");
      for (int j = c; j < 7; ++j) a[r][j] -= f * a[c][j];
    }
  }
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) coefficients[mesh * 12 + i * 3 + j] = a[i][4 + j] / a[i][i];
}

__global__ void affineBlend(MeshView m, const float3* g, const double* coefficients, float share) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const double* c = coefficients + m.meshOf[v] * 12;
  const double h[4] = {m.x[v].x, m.x[v].y, m.x[v].z, 1.0};
  double fit[3] = {0.0, 0.0, 0.0};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 3; ++j) fit[j] += h[i] * c[i * 3 + j];
  const bool usable = isfinite(fit[0]) && isfinite(fit[1]) && isfinite(fit[2]);
  const float3 own = g[v];
  const float3 affine = usable ? make_float3(float(fit[0]), float(fit[1]), float(fit[2])) : own;
  m.force[v].x += share * affine.x + (1.0f - share) * own.x;
  m.force[v].y += share * affine.y + (1.0f - share) * own.y;
  m.force[v].z += share * affine.z + (1.0f - share) * own.z;
}
}  // namespace

void launchAffineRegularisation(const MeshView& m, const float3* imageForce, const int* meshBegin, const int* meshEnd,
                                int meshes, int parts, double* moments, double* coefficients, float share,
                                cudaStream_t s) {
  affineMoments<<<dim3(parts, meshes), kMomentThreads, 0, s>>>(m.x, imageForce, meshBegin, meshEnd, moments);
  affineSolve<<<(meshes + 63) / 64, 64, 0, s>>>(moments, parts, coefficients, meshes);
  affineBlend<<<(m.vertices + 255) / 256, 256, 0, s>>>(m, imageForce, coefficients, share);
}

}  // namespace sinew::cuda

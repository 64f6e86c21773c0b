// Multi-resolution forces (paper 001 section 2.1) on the device: a coarser level's positions are
// gathered from the current level's (coarse vertex t is fine vertex 4^k t), and its forces are
// carried back up by the prolongation and added, as Simulation::addCoarseForces does on the CPU.
#include "kernels.h"

namespace sinew::cuda {

namespace {
constexpr unsigned kThreads = 256;
unsigned blocks(int n) { return (n + kThreads - 1) / kThreads; }

__global__ void gather(const int* index, int count, const float3* from, float3* to) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i < count) to[i] = from[index[i]];
}

// fine[i] += scale * sum_k weight[k] * coarse[index[k]], in the CPU's order (Prolongation::apply).
__global__ void prolongAdd(const int* rows, const int* index, const float* weight, int count, const float3* coarse,
                           float3* fine, float scale) {
  const int i = blockIdx.x * blockDim.x + threadIdx.x;
  if (i >= count) return;
  float3 acc = make_float3(0.0f, 0.0f, 0.0f);
  for (int k = rows[i]; k < rows[i + 1]; ++k) {
    const float3 c = coarse[index[k]];
    acc.x += weight[k] * c.x;
    acc.y += weight[k] * c.y;
    acc.z += weight[k] * c.z;
  }
  fine[i].x += scale * acc.x;
  fine[i].y += scale * acc.y;
  fine[i].z += scale * acc.z;
}
}  // namespace

void launchGather(const int* index, int count, const float3* from, float3* to, cudaStream_t s) {
  gather<<<blocks(count), kThreads, 0, s>>>(index, count, from, to);
}

void launchProlongAdd(const int* rows, const int* index, const float* weight, int count, const float3* coarse,
                      float3* fine, float scale, cudaStream_t s) {
  prolongAdd<<<blocks(count), kThreads, 0, s>>>(rows, index, weight, count, coarse, fine, scale);
}

}  // namespace sinew::cuda

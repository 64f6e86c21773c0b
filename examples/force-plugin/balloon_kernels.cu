#include "balloon_kernels.h"

namespace sinew {
namespace {
__global__ void balloonKernel(cuda::MeshView m, cuda::ParamView p, int pressure) {
  const int v = blockIdx.x * blockDim.x + threadIdx.x;
  if (v >= m.vertices) return;
  const int mesh = m.meshOf[v];
  const float alpha = p.at(mesh, 0);
  if (!(alpha > 0.0f)) return;
  const float s = alpha * p.at(mesh, pressure);
  const float3 n = m.normal[v];
  float3 f = m.force[v];
  f.x += s * n.x;
  f.y += s * n.y;
  f.z += s * n.z;
  m.force[v] = f;
}
}  // namespace

cudaError_t launchBalloon(const cuda::MeshView& mesh, cuda::ParamView params, int pressure, cudaStream_t stream) {
  constexpr int kThreads = 256;
  balloonKernel<<<(mesh.vertices + kThreads - 1) / kThreads, kThreads, 0, stream>>>(mesh, params, pressure);
  return cudaGetLastError();  // this plugin's CUDA runtime: the engine cannot see it
}
}  // namespace sinew

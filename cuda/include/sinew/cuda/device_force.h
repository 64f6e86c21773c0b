// A force's CUDA path, as a plugin writes it: typed views of the device mesh store (the host
// MeshStore's arrays mirrored one to one) and of the force's per-structure parameters. A force with
// a CUDA path derives from both sinew::Force and sinew::cuda::DeviceForce and returns `this` from
// Force::deviceForce(); the CUDA backend then runs it on the device (docs/plugins.md).
// Needs only the CUDA runtime headers: host code and .cu files include it alike.
#pragma once

#include <cuda_runtime.h>

namespace sinew {
class ParamTable;
}

namespace sinew::cuda {

// The device side of the mesh store. Indices are global (all structures concatenated), as on the
// host. Derived arrays (normal, elevation, area, mass, cellCentre) are null unless some force or
// the integrator required them; they are up to date for the step when a force runs.
struct MeshView {
  int vertices = 0, cells = 0;
  const int3* neighbours = nullptr;   // three per vertex
  const int3* vertexCells = nullptr;  // three per vertex
  const int* cellOffsets = nullptr;   // cells + 1 entries into cellVertices
  const int* cellVertices = nullptr;
  const int* meshOf = nullptr;        // the structure of each vertex
  const float* density = nullptr;     // per structure
  const float* massFloor = nullptr;   // per structure, the least vertex mass; null: none
  float3* x = nullptr;                // positions
  float3* prev = nullptr;             // previous positions
  float3* force = nullptr;            // the step's force: add to it, never overwrite
  float3* normal = nullptr;           // outward unit normals (Attribute::Normal)
  float* elevation = nullptr;
  float* area = nullptr;
  float* mass = nullptr;
  float3* cellCentre = nullptr;
};

// One force's parameters in device memory: values[mesh * count + p]; p = 0 is the weight alpha,
// then the force's own parameters in declaration order.
struct ParamView {
  const float* values = nullptr;
  int count = 0;
  __host__ __device__ float at(int mesh, int p) const { return values[mesh * count + p]; }
};

struct DeviceForceContext {
  const MeshView& mesh;
  ParamView params;              // device memory
  const ParamTable& hostParams;  // the same values on the host (indexOf, shared values)
  cudaStream_t stream;
};

// Both calls return the CUDA error state of the plugin's own code (cudaGetLastError() where it was
// compiled): a plugin linking its own CUDA runtime keeps its errors there, out of the engine's
// sight. The engine stops with an error naming the force on anything but cudaSuccess.
class DeviceForce {
public:
  virtual ~DeviceForce() = default;
  // Called outside graph capture whenever the engine (re)builds its device store: at start, after a
  // host edit and after a level change (the mesh sizes change). Allocate or upload here what the
  // force keeps on the device; the plugin's CUDA runtime also initialises here, not inside a capture.
  virtual cudaError_t prepare(const DeviceForceContext&) { return cudaSuccess; }
  // Adds alpha * f to mesh.force for every vertex whose structure's alpha is positive. Enqueue
  // kernels on ctx.stream only: no synchronisation, allocation or copy to the host, because the
  // calls are captured into a CUDA graph once and replayed (captured again when a parameter shared
  // by all structures or a force's on/off state changes).
  virtual cudaError_t enqueue(const DeviceForceContext& ctx) = 0;
  // After the step's move: the device side of Force::constrain (moves mesh.x), enqueued the same way.
  virtual cudaError_t constrain(const DeviceForceContext&) { return cudaSuccess; }
};

}  // namespace sinew::cuda

// The CUDA backend: the mesh store mirrored on the GPU (same structure-of-arrays layout), every
// built-in force and damped Verlet as kernels. State stays on the device while it runs; only
// parameters (and attraction points) go up before a batch, and positions come back on request.
// Host-only header: no CUDA types, so the CLI and tests include it freely.
#pragma once

#include "sinew/core/execution_backend.h"
#include "sinew/core/simulation.h"

#include <memory>
#include <string>
#include <vector>

namespace sinew::cuda {

struct DeviceStatus {
  bool usable = false;
  std::string description;  // e.g. "NVIDIA H100 80GB HBM3 (sm_90, 79.1 GiB)"
  std::string reason;       // why not usable
};

// Never throws: reports whether a CUDA device this build can use is present.
DeviceStatus probeDevice();
// probeDevice(), then the device's context created (the first CUDA call's cost, a few tenths of a
// second), so that a later CudaEngine starts at once. Never throws.
DeviceStatus startDevice();
// The visible devices this build can use (compute capability 9.0 or later), by CUDA index. Never throws.
std::vector<int> usableDevices();

class CudaEngine final : public ExecutionBackend {
public:
  // Mirrors an initialised simulation on the device. Throws std::runtime_error when a force or the
  // integrator has no CUDA implementation or the device runs out of memory.
  explicit CudaEngine(Simulation& simulation);
  ~CudaEngine() override;
  CudaEngine(const CudaEngine&) = delete;
  CudaEngine& operator=(const CudaEngine&) = delete;

  // Runs iterations on the device (captured as CUDA Graph batches). Host state is not updated.
  void run(int iterations) override;
  // Copies positions, previous positions and forces back into the host store.
  void download() override;
  // Uploads the host store again (after a host-side edit).
  void reload() override;
  void restoreState() override;
  // After Simulation::advanceLevel(): positions and previous positions are prolongated on the
  // device (the state never visits the host); topology, reference and profiles come from the host.
  void levelChanged() override;
  // The sampled error on the device: only the distances come back (device_error.h).
  bool measureError(SampledError& error, std::vector<std::optional<SurfaceDistanceStats>>& out) override;
  // The exact evaluation's distances on the device (the hierarchy and points uploaded, the
  // distances downloaded; nothing kept).
  bool closestDistances(const TriangleBvh& meshes, std::span<const collision::P3> points, std::span<const int> roots,
                        std::span<float> out) override;

  // Drawing from the device store (the workstation's interop path). Structure `mesh`'s
  // tessellation points, vertices then cell centres, as packed xyz floats, written to device memory
  // (a mapped OpenGL buffer). Asynchronous on the engine's stream: unmapping the buffer on that
  // stream (or synchronize()) orders it before the drawing.
  void writeSurfacePoints(Index mesh, float* deviceOut);
  // Where every structure's tessellation crosses the plane normal . x = offset, computed on the
  // device in one pass: per structure, segment end points in pairs. Only the segments cross to the
  // host.
  std::vector<std::vector<Vec3>> contourSegments(const Vec3& normal, float offset);
  // The engine's CUDA stream (a cudaStream_t), for work that must be ordered with it.
  void* nativeStream() const;
  void synchronize();

  std::string name() const override { return "cuda"; }
  std::string device() const override;
  std::size_t deviceBytes() const;  // device memory the engine holds

private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace sinew::cuda

#include "device_error.h"

namespace sinew::cuda {

void DeviceSampledError::uploadTruth(const SampledError& error, cudaStream_t stream) {
  truthNodes_.upload(error.truth().nodes, stream);
  truthCorners_.upload(error.truth().corners, stream);
  truthRoots_.upload(error.truthRoots(), stream);
  std::vector<float3> points;
  std::vector<float> areas;
  for (const SurfaceSample& s : error.truthSamples()) {
    points.push_back(make_float3(s.point.x(), s.point.y(), s.point.z()));
    areas.push_back(s.area);
  }
  samples_.upload(points, stream);
  sampleAreas_.upload(areas, stream);
  samplePatch_.upload(error.samplePatch(), stream);
  patchCentres_.upload(error.patchCentres(), stream);
  patchStructure_.upload(error.patchStructure(), stream);
  planes_.resize(error.patchCentres().size());
  fromTruth_.resize(points.size());
  SINEW_CUDA(cudaStreamSynchronize(stream));  // the host vectors go out of scope
  truthOf_ = &error;
}

void DeviceSampledError::uploadMeshes(const SampledError& error, cudaStream_t stream) {
  const TriangleBvh& bvh = error.meshes();
  std::vector<int> parents(bvh.nodes.size(), -1), leaves;
  for (size_t id = 0; id < bvh.nodes.size(); ++id) {
    const trianglebvh::Node& n = bvh.nodes[id];
    if (n.left < 0) leaves.push_back(int(id));
    else parents[n.left] = parents[n.right] = int(id);
  }
  std::vector<int3> triangles;
  for (const auto& t : bvh.triangles) triangles.push_back(make_int3(int(t[0]), int(t[1]), int(t[2])));
  meshNodes_.upload(bvh.nodes, stream);
  parents_.upload(parents, stream);
  leaves_.upload(leaves, stream);
  triangles_.upload(triangles, stream);
  triangleStructure_.upload(error.meshTriangleStructure(), stream);
  meshRoots_.upload(error.meshRoots(), stream);
  corners_.resize(bvh.corners.size());
  visits_.resize(bvh.nodes.size());
  toTruth_.resize(size_t(error.samplesPerTriangle()) * triangles.size());
  SINEW_CUDA(cudaStreamSynchronize(stream));
}

std::vector<std::optional<SurfaceDistanceStats>> DeviceSampledError::measure(SampledError& error, MeshStore& store,
                                                                             const MeshView& view, cudaStream_t stream) {
  if (truthOf_ != &error) {
    uploadTruth(error, stream);
    error.prepare(store);
    uploadMeshes(error, stream);
  } else if (error.prepare(store)) {
    uploadMeshes(error, stream);
  }
  points_.resize(size_t(view.vertices + view.cells));
  SampledErrorDevice e;
  e.meshNodes = meshNodes_.get();
  e.parents = parents_.get();
  e.leaves = leaves_.get();
  e.triangles = triangles_.get();
  e.triangleStructure = triangleStructure_.get();
  e.meshRoots = meshRoots_.get();
  e.points = points_.get();
  e.corners = corners_.get();
  e.visits = visits_.get();
  e.truthNodes = truthNodes_.get();
  e.truthCorners = truthCorners_.get();
  e.truthRoots = truthRoots_.get();
  e.samples = samples_.get();
  e.sampleAreas = sampleAreas_.get();
  e.samplePatch = samplePatch_.get();
  e.patchCentres = patchCentres_.get();
  e.patchStructure = patchStructure_.get();
  e.planes = planes_.get();
  e.toTruth = toTruth_.get();
  e.fromTruth = fromTruth_.get();
  e.meshNodeCount = int(meshNodes_.size());
  e.leafCount = int(leaves_.size());
  e.triangleCount = int(triangles_.size());
  e.sampleCount = int(samples_.size());
  e.patchCount = int(patchCentres_.size());
  e.samplesPerTriangle = error.samplesPerTriangle();
  launchSampledError(view, e, stream);
  hostTo_.resize(toTruth_.size());
  hostFrom_.resize(fromTruth_.size());
  hostPlanes_.resize(planes_.size());
  toTruth_.download(hostTo_.data(), hostTo_.size(), stream);
  fromTruth_.download(hostFrom_.data(), hostFrom_.size(), stream);
  if (error.samplesPerTriangle() == 1) planes_.download(hostPlanes_.data(), hostPlanes_.size(), stream);
  SINEW_CUDA(cudaStreamSynchronize(stream));
  SINEW_CUDA(cudaGetLastError());
  error.applyCurvature(hostPlanes_, hostFrom_, store.executor());  // the host's, as for a host measure
  return error.summarise(hostTo_, hostFrom_, store.executor());
}

std::size_t DeviceSampledError::bytes() const {
  return truthNodes_.bytes() + meshNodes_.bytes() + truthCorners_.bytes() + corners_.bytes() + points_.bytes() +
         truthRoots_.bytes() + samplePatch_.bytes() + patchStructure_.bytes() + patchCentres_.bytes() + planes_.bytes() + parents_.bytes() + leaves_.bytes() + triangleStructure_.bytes() +
         meshRoots_.bytes() + visits_.bytes() + triangles_.bytes() + samples_.bytes() + sampleAreas_.bytes() +
         toTruth_.bytes() + fromTruth_.bytes();
}

void closestDistancesOnDevice(const TriangleBvh& meshes, std::span<const collision::P3> points, std::span<const int> roots,
                              std::span<float> out, cudaStream_t stream) {
  if (points.size() != roots.size() || points.size() != out.size())
    throw std::logic_error("closestDistances: points, roots and out differ in size");
  if (points.empty()) return;
  DeviceArray<trianglebvh::Node> nodes;
  DeviceArray<collision::P3> corners, devicePoints;
  DeviceArray<int> deviceRoots;
  DeviceArray<float> distances(points.size());
  nodes.upload(meshes.nodes, stream);
  corners.upload(meshes.corners, stream);
  devicePoints.upload(points.data(), points.size(), stream);
  deviceRoots.upload(roots.data(), roots.size(), stream);
  launchClosestDistances(nodes.get(), corners.get(), devicePoints.get(), deviceRoots.get(), int(points.size()),
                         distances.get(), stream);
  distances.download(out.data(), out.size(), stream);
  SINEW_CUDA(cudaStreamSynchronize(stream));
  SINEW_CUDA(cudaGetLastError());
}

}  // namespace sinew::cuda

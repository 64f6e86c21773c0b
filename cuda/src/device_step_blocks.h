// The blocks of launchStepInBlocks (kernels.h): per block of kStepBlock consecutive vertices, its
// connectivity as indices into its own shared arrays. Built on the host once per level
// (buildStepBlocks, which runs without a GPU), then uploaded. Host-only header.
#pragma once

#include "cuda_check.h"
#include "kernels.h"

#include <array>
#include <optional>
#include <vector>

namespace sinew {
class MeshStore;
}

namespace sinew::cuda {

// StepBlocks' arrays on the host (kernels.h says what each holds).
struct StepBlockArrays {
  std::vector<std::array<int, 4>> start;
  std::vector<int> vertices;
  std::vector<std::array<int, 3>> geometry;
  std::vector<unsigned short> cellEnd, cellSlots;
  StepBlockLayout layout;  // for the largest block's counts
};
// Nothing where a block would need more positions, cells or cell entries than 16 bits address, or
// more than 48 KiB of shared memory.
std::optional<StepBlockArrays> buildStepBlocks(const MeshStore& s);

class DeviceStepBlocks {
public:
  // False, with nothing kept, where buildStepBlocks gives nothing.
  bool upload(const MeshStore& s, cudaStream_t stream);
  void clear();
  bool ready() const { return start_.size() > 0; }
  StepBlocks view() const {
    return {start_.get(), vertices_.get(), geometry_.get(), cellEnd_.get(), cellSlots_.get(), layout_};
  }
  std::size_t bytes() const {
    return start_.bytes() + vertices_.bytes() + geometry_.bytes() + cellEnd_.bytes() + cellSlots_.bytes();
  }

private:
  DeviceArray<int4> start_;
  DeviceArray<int> vertices_;
  DeviceArray<int3> geometry_;
  DeviceArray<unsigned short> cellEnd_, cellSlots_;
  StepBlockLayout layout_;
};

}  // namespace sinew::cuda

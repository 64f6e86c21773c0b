// The attachments of the current level in device memory (core/attachments.h builds them on the
// host at each level; attachment_kernels.cu applies them). Host C++ only.
#pragma once

#include "cuda_check.h"
#include "kernels.h"
#include "sinew/core/attachments.h"

namespace sinew::cuda {

class DeviceAttachments {
public:
  void upload(const AttachmentArrays& arrays, cudaStream_t stream);
  bool empty() const { return view_.mergedCount + view_.fixedCount + view_.attachedCount == 0; }
  const AttachmentDevice& view() const { return view_; }
  std::size_t bytes() const;

private:
  DeviceArray<int> mergedA_, mergedB_, fixedVertex_, attachedVertex_, attachedOffsets_, attachedSource_;
  DeviceArray<float3> mergedOffset_, fixedAt_, attachedOffset_;
  DeviceArray<float> mergedShare_, attachedWeight_;
  AttachmentDevice view_;
};

}  // namespace sinew::cuda

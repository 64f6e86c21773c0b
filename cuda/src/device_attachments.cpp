#include "device_attachments.h"

#include "device_store.h"

namespace sinew::cuda {

void DeviceAttachments::upload(const AttachmentArrays& a, cudaStream_t stream) {
  mergedA_.upload(a.mergedA, stream);
  mergedB_.upload(a.mergedB, stream);
  uploadAs(mergedOffset_, std::span<const Vec3>(a.mergedOffset), stream);
  mergedShare_.resize(a.mergedA.size());
  fixedVertex_.upload(a.fixedVertex, stream);
  uploadAs(fixedAt_, std::span<const Vec3>(a.fixedAt), stream);
  attachedVertex_.upload(a.attachedVertex, stream);
  attachedOffsets_.upload(a.attachedOffsets, stream);
  attachedSource_.upload(a.attachedSource, stream);
  attachedWeight_.upload(a.attachedWeight, stream);
  uploadAs(attachedOffset_, std::span<const Vec3>(a.attachedOffset), stream);
  view_ = AttachmentDevice{};
  view_.mergedA = mergedA_.get();
  view_.mergedB = mergedB_.get();
  view_.mergedOffset = mergedOffset_.get();
  view_.mergedShare = mergedShare_.get();
  view_.fixedVertex = fixedVertex_.get();
  view_.fixedAt = fixedAt_.get();
  view_.attachedVertex = attachedVertex_.get();
  view_.attachedOffsets = attachedOffsets_.get();
  view_.attachedSource = attachedSource_.get();
  view_.attachedWeight = attachedWeight_.get();
  view_.attachedOffset = attachedOffset_.get();
  view_.mergedCount = int(a.mergedA.size());
  view_.fixedCount = int(a.fixedVertex.size());
  view_.attachedCount = int(a.attachedVertex.size());
  view_.attachedInOrder = a.attachedInOrder;
}

std::size_t DeviceAttachments::bytes() const {
  return mergedA_.bytes() + mergedB_.bytes() + fixedVertex_.bytes() + attachedVertex_.bytes() + attachedOffsets_.bytes() +
         attachedSource_.bytes() + mergedOffset_.bytes() + fixedAt_.bytes() + attachedOffset_.bytes() + mergedShare_.bytes() +
         attachedWeight_.bytes();
}

}  // namespace sinew::cuda

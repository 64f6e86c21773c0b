// The balloon force's CUDA launcher: typed views in, no void*; returns the launch's error state.
#pragma once

#ifdef BALLOON_WITH_CUDA
#include <sinew/cuda/device_force.h>

namespace sinew {
cudaError_t launchBalloon(const cuda::MeshView& mesh, cuda::ParamView params, int pressure, cudaStream_t stream);
}
#endif

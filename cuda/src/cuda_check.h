// Host-only CUDA helpers: checked calls, RAII device arrays, launch geometry, a stream branch.
#pragma once

#include <cuda_runtime.h>

#include <stdexcept>
#include <string>
#include <vector>

namespace sinew::cuda {

// Out of device memory (a scene too large for the GPU, or a GPU others fill) is not sticky: the
// message says how much is free, and the caller falls back to the CPU (backend_choice.h,
// SceneRunner::run, the workstation's session).
inline void check(cudaError_t e, const char* what) {
  if (e == cudaSuccess) return;
  std::string message = std::string("CUDA: ") + what + ": " + cudaGetErrorString(e);
  if (e == cudaErrorMemoryAllocation) {
    cudaGetLastError();  // clears it
    std::size_t freeBytes = 0, totalBytes = 0;
    if (cudaMemGetInfo(&freeBytes, &totalBytes) == cudaSuccess)
      message += " (" + std::to_string(freeBytes >> 20) + " MiB free of " + std::to_string(totalBytes >> 20) +
                 " MiB: the scene does not fit in this GPU's free memory)";
  }
  throw std::runtime_error(message);
}
#define SINEW_CUDA(call) ::sinew::cuda::check((call), #call)

inline unsigned blocksFor(std::size_t n, unsigned threads) { return static_cast<unsigned>((n + threads - 1) / threads); }

// Device memory owned by one object; copies only through upload/download.
template <class T>
class DeviceArray {
public:
  DeviceArray() = default;
  explicit DeviceArray(std::size_t n) { resize(n); }
  ~DeviceArray() { release(); }
  DeviceArray(const DeviceArray&) = delete;
  DeviceArray& operator=(const DeviceArray&) = delete;
  DeviceArray(DeviceArray&& o) noexcept : ptr_(o.ptr_), size_(o.size_) { o.ptr_ = nullptr, o.size_ = 0; }
  DeviceArray& operator=(DeviceArray&& o) noexcept {
    std::swap(ptr_, o.ptr_);
    std::swap(size_, o.size_);
    return *this;
  }

  void resize(std::size_t n) {
    if (n == size_) return;
    release();
    if (n) SINEW_CUDA(cudaMalloc(&ptr_, n * sizeof(T)));
    size_ = n;
  }
  void upload(const T* host, std::size_t n, cudaStream_t s = 0) {
    resize(n);
    if (n) SINEW_CUDA(cudaMemcpyAsync(ptr_, host, n * sizeof(T), cudaMemcpyHostToDevice, s));
  }
  void upload(const std::vector<T>& host, cudaStream_t s = 0) { upload(host.data(), host.size(), s); }
  void download(T* host, std::size_t n, cudaStream_t s = 0) const {
    if (n) SINEW_CUDA(cudaMemcpyAsync(host, ptr_, n * sizeof(T), cudaMemcpyDeviceToHost, s));
  }
  T* get() const { return ptr_; }
  std::size_t size() const { return size_; }
  std::size_t bytes() const { return size_ * sizeof(T); }

private:
  void release() {
    if (ptr_) cudaFree(ptr_);
    ptr_ = nullptr;
    size_ = 0;
  }
  T* ptr_ = nullptr;
  std::size_t size_ = 0;
};

// A branch of work beside a stream: begin() returns a second stream that starts where `main` is
// now, follow() makes it wait for what `main` has enqueued since, join() makes `main` wait for
// everything enqueued on it. Works under stream capture (the branch becomes a parallel path of the
// graph); every begin() must be joined before the capture ends. The branch's stream has the
// device's highest priority: it is the longer path.
class StreamBranch {
public:
  StreamBranch() = default;
  ~StreamBranch() { release(); }
  StreamBranch(const StreamBranch&) = delete;
  StreamBranch& operator=(const StreamBranch&) = delete;

  cudaStream_t begin(cudaStream_t main) {
    if (!side_) {
      int least = 0, greatest = 0;
      SINEW_CUDA(cudaDeviceGetStreamPriorityRange(&least, &greatest));
      SINEW_CUDA(cudaStreamCreateWithPriority(&side_, cudaStreamNonBlocking, greatest));
      SINEW_CUDA(cudaEventCreateWithFlags(&fork_, cudaEventDisableTiming));
      SINEW_CUDA(cudaEventCreateWithFlags(&follow_, cudaEventDisableTiming));
      SINEW_CUDA(cudaEventCreateWithFlags(&join_, cudaEventDisableTiming));
    }
    SINEW_CUDA(cudaEventRecord(fork_, main));
    SINEW_CUDA(cudaStreamWaitEvent(side_, fork_, 0));
    return side_;
  }
  void follow(cudaStream_t main) {
    SINEW_CUDA(cudaEventRecord(follow_, main));
    SINEW_CUDA(cudaStreamWaitEvent(side_, follow_, 0));
  }
  void join(cudaStream_t main) {
    SINEW_CUDA(cudaEventRecord(join_, side_));
    SINEW_CUDA(cudaStreamWaitEvent(main, join_, 0));
  }

private:
  void release() {
    if (join_) cudaEventDestroy(join_);
    if (follow_) cudaEventDestroy(follow_);
    if (fork_) cudaEventDestroy(fork_);
    if (side_) cudaStreamDestroy(side_);
  }
  cudaStream_t side_ = nullptr;
  cudaEvent_t fork_ = nullptr, follow_ = nullptr, join_ = nullptr;
};

}  // namespace sinew::cuda

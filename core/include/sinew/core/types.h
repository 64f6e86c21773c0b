// Basic value types shared by the engine and the backends.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <stdexcept>
#include <string>

namespace sinew {

// 12 bytes, no padding: the same layout as CUDA's float3, so host arrays of Vec3 can be copied to
// and viewed from the device as they are.
using Vec3 = Eigen::Vector3f;
using Index = std::int32_t;

static_assert(sizeof(Vec3) == 3 * sizeof(float), "Vec3 must be tightly packed");

// Thrown for input the engine refuses (a malformed mesh, an unknown parameter...). The message is
// meant for the user: it names the offending element.
class InputError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

// Thrown when the simulation state becomes non-finite or explodes and cannot be recovered.
class NumericalError : public std::runtime_error {
public:
  using std::runtime_error::runtime_error;
};

}  // namespace sinew

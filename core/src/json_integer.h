// A JSON number as an integer of T's range, checked first: nlohmann-json's get<int>() casts a
// number like 1e46 or 2^40 without a check (undefined behaviour, or a wrapped value; found by
// fuzz_model). Private to core (scene.cpp, model_file.cpp).
#pragma once

#include <nlohmann/json.hpp>

#include <cstdint>
#include <limits>
#include <optional>

namespace sinew {

template <class T>
std::optional<T> integerOf(const nlohmann::ordered_json& v) {
  if (v.is_number_unsigned()) {
    const std::uint64_t u = v.get<std::uint64_t>();
    if (u > std::uint64_t(std::numeric_limits<T>::max())) return std::nullopt;
    return T(u);
  }
  if (!v.is_number_integer()) return std::nullopt;
  const std::int64_t i = v.get<std::int64_t>();
  if (i < std::int64_t(std::numeric_limits<T>::min())) return std::nullopt;
  if (i > 0 && std::uint64_t(i) > std::uint64_t(std::numeric_limits<T>::max())) return std::nullopt;
  return T(i);
}

}  // namespace sinew

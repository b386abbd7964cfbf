#pragma once
// Integer fields of JSON metadata, read strictly. nlohmann's get<int>() converts any number with
// a plain cast: a damaged file's 1e120 read as an int is undefined behaviour (found by
// tests/fuzz), and 3.7 or 2^40 silently become other numbers. These accept only an integer in
// T's range and otherwise throw nlohmann's own type_error, so a reader's json::exception handler
// still turns it into a wm::Error naming the file and key.
#include <concepts>
#include <cstdint>
#include <limits>
#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

namespace wm {

template <std::integral T>
T JsonInt(const nlohmann::json& j) {
  if (j.is_number_unsigned() && std::in_range<T>(j.get<uint64_t>())) {
    return static_cast<T>(j.get<uint64_t>());
  }
  if (j.is_number_integer() && !j.is_number_unsigned() && std::in_range<T>(j.get<int64_t>())) {
    return static_cast<T>(j.get<int64_t>());
  }
  throw nlohmann::json::type_error::create(
      302,
      "expected an integer in [" + std::to_string(std::numeric_limits<T>::min()) + ", " +
          std::to_string(std::numeric_limits<T>::max()) + "], got " +
          (j.is_number() ? j.dump() : std::string(j.type_name())),
      &j);
}

// An array of integers, each as JsonInt<T>.
template <std::integral T>
std::vector<T> JsonInts(const nlohmann::json& j) {
  if (!j.is_array()) {
    throw nlohmann::json::type_error::create(
        302, std::string("expected an array of integers, got ") + j.type_name(), &j);
  }
  std::vector<T> out;
  for (const nlohmann::json& v : j) out.push_back(JsonInt<T>(v));
  return out;
}

}  // namespace wm

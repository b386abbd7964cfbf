#pragma once
// Typed access to one parsed tf.train.Example, with errors that name the key and what was
// expected. The protobuf types stay inside example.cc.
#include <cstdint>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace wm::rlds {

class Example {
 public:
  // Throws wm::Error when `bytes` is not a valid serialized tf.train.Example.
  explicit Example(std::string_view bytes);
  ~Example();
  Example(Example&&) noexcept;

  bool Has(const std::string& key) const;
  std::vector<std::string> Keys() const;  // sorted
  // Each throws wm::Error(key) if the key is missing or holds another list type.
  std::vector<std::string> Bytes(const std::string& key) const;
  std::vector<float> Floats(const std::string& key) const;
  std::vector<int64_t> Int64s(const std::string& key) const;
  // "bytes", "float", "int64" or "missing".
  std::string KindOf(const std::string& key) const;
  size_t Count(const std::string& key) const;  // number of values

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Builds a serialized tf.train.Example (used by the tabletop generator and tests).
class ExampleBuilder {
 public:
  ExampleBuilder();
  ~ExampleBuilder();
  void AddBytes(const std::string& key, const std::vector<std::string>& values);
  void AddFloats(const std::string& key, const std::vector<float>& values);
  void AddInt64s(const std::string& key, const std::vector<int64_t>& values);
  // Deterministic serialization (map entries sorted), so generated files are reproducible.
  std::string Serialize() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace wm::rlds

#pragma once
// Length-prefixed fields for bytes that travel between two copies of the same binary (a parent
// and the child process it forked, core/child_process.h): each field is a native-endian u64 byte
// count and its bytes. Not a file format: nothing here is meant to outlive the process pair.
#include <cstdint>
#include <cstring>
#include <string>
#include <string_view>
#include <type_traits>
#include <vector>

#include "core/error.h"

namespace wm::bytes {

inline void Put(std::string& out, const void* data, uint64_t size) {
  out.append(reinterpret_cast<const char*>(&size), sizeof(size));
  out.append(static_cast<const char*>(data), size);
}
inline void Put(std::string& out, std::string_view s) { Put(out, s.data(), s.size()); }
template <class T>
void Put(std::string& out, const std::vector<T>& v) {
  static_assert(std::is_trivially_copyable_v<T>);
  Put(out, v.data(), v.size() * sizeof(T));
}
inline void Put(std::string& out, int64_t v) { Put(out, &v, sizeof(v)); }
inline void Put(std::string& out, int32_t v) { Put(out, int64_t{v}); }

// Reads fields back in the order they were put; throws wm::Error on bytes that do not parse.
class Reader {
 public:
  explicit Reader(std::string_view bytes) : bytes_(bytes) {}

  // The next field's bytes, whose size must be a multiple of `unit`.
  std::string_view Next(size_t unit = 1) {
    uint64_t n = 0;
    Check(bytes_.size() - pos_ >= sizeof(n), "packed bytes are truncated");
    std::memcpy(&n, bytes_.data() + pos_, sizeof(n));
    pos_ += sizeof(n);
    Check(n <= bytes_.size() - pos_ && n % unit == 0, "packed bytes have a bad field size");
    std::string_view field = bytes_.substr(pos_, n);
    pos_ += n;
    return field;
  }
  template <class T>
  void Take(std::vector<T>& v) {
    std::string_view f = Next(sizeof(T));
    v.resize(f.size() / sizeof(T));
    if (!f.empty()) std::memcpy(v.data(), f.data(), f.size());
  }
  void Take(std::string& s) { s = std::string(Next()); }
  void Take(int64_t& v) {
    std::string_view f = Next();
    Check(f.size() == sizeof(v), "packed bytes have a bad integer");
    std::memcpy(&v, f.data(), sizeof(v));
  }
  void Take(int32_t& v) {
    int64_t wide = 0;
    Take(wide);
    Check(wide >= INT32_MIN && wide <= INT32_MAX, "packed bytes have a bad integer");
    v = static_cast<int32_t>(wide);
  }
  bool done() const { return pos_ == bytes_.size(); }

 private:
  std::string_view bytes_;
  size_t pos_ = 0;
};

}  // namespace wm::bytes

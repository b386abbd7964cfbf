#pragma once
// SHA-256 content hashes (OpenSSL), as lowercase hex: used for input, shard and config hashes.
#include <memory>
#include <string>
#include <string_view>

namespace wm {

class Sha256 {
 public:
  Sha256();
  ~Sha256();
  Sha256(const Sha256&) = delete;
  Sha256& operator=(const Sha256&) = delete;
  void Update(const void* data, size_t n);
  void Update(std::string_view s) { Update(s.data(), s.size()); }
  std::string HexDigest();  // finishes the hash

 private:
  struct State;
  std::unique_ptr<State> state_;
};

std::string Sha256Hex(std::string_view data);
// Hash of a whole file, streamed; throws wm::Error naming the file if it cannot be read.
std::string Sha256File(const std::string& path);

}  // namespace wm

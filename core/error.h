#pragma once
// wm::Error: the one exception type of wmkit. It carries where the problem is (file, record,
// key) so that main() can print one line a user can act on.
#include <cstdint>
#include <optional>
#include <stdexcept>
#include <string>

namespace wm {

struct ErrorContext {
  std::string file;               // the file being read or written, if any
  std::optional<int64_t> record;  // record / episode / step index within the file
  std::string record_label;       // what `record` counts ("record", "episode", "demo"...)
  std::string key;                // feature key, JSON field or section name
};

class Error : public std::runtime_error {
 public:
  explicit Error(const std::string& what, ErrorContext context = {});
  const ErrorContext& context() const { return context_; }
  const std::string& message() const { return message_; }

  // A copy of this error with more context (fields already set are kept).
  Error WithFile(const std::string& file) const;
  Error WithRecord(int64_t record, const std::string& label = "record") const;
  Error WithKey(const std::string& key) const;

 private:
  static std::string Format(const std::string& message, const ErrorContext& context);
  std::string message_;
  ErrorContext context_;
};

// Throws wm::Error(message, context) when `condition` is false.
inline void Check(bool condition, const std::string& message, const ErrorContext& context = {}) {
  if (!condition) throw Error(message, context);
}

}  // namespace wm

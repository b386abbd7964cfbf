#include "core/error.h"

namespace wm {

Error::Error(const std::string& what, ErrorContext context)
    : std::runtime_error(Format(what, context)), message_(what), context_(std::move(context)) {}

std::string Error::Format(const std::string& message, const ErrorContext& c) {
  std::string out;
  if (!c.file.empty()) out += c.file;
  if (c.record) {
    out += out.empty() ? "" : ": ";
    out += (c.record_label.empty() ? "record" : c.record_label) + " " + std::to_string(*c.record);
  }
  if (!c.key.empty()) {
    out += out.empty() ? "" : ": ";
    out += "key '" + c.key + "'";
  }
  return out.empty() ? message : out + ": " + message;
}

Error Error::WithFile(const std::string& file) const {
  ErrorContext c = context_;
  if (c.file.empty()) c.file = file;
  return Error(message_, c);
}

Error Error::WithRecord(int64_t record, const std::string& label) const {
  ErrorContext c = context_;
  if (!c.record) {
    c.record = record;
    c.record_label = label;
  }
  return Error(message_, c);
}

Error Error::WithKey(const std::string& key) const {
  ErrorContext c = context_;
  if (c.key.empty()) c.key = key;
  return Error(message_, c);
}

}  // namespace wm

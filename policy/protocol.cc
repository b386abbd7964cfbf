#include "policy/protocol.h"

#include <cmath>
#include <limits>
#include <nlohmann/json.hpp>
#include <regex>

#include "core/error.h"

namespace wm::policy {
namespace {

using nlohmann::json;

std::string Line(const json& j) { return j.dump() + "\n"; }

// The start of a bad line, printable, for an error message.
std::string Quote(std::string_view line) {
  std::string out;
  for (char c : line.substr(0, 80)) {
    const auto u = static_cast<unsigned char>(c);
    out += (u >= 0x20 && u < 0x7f) ? c : '?';
  }
  return "'" + out + (line.size() > 80 ? "...'" : "'");
}

// Python's json.dumps writes NaN, Infinity and -Infinity, which JSON has no words for. A line
// that only parses with them replaced by marker values is read that way, so that the action
// check can name the value instead of calling the whole line malformed.
constexpr double kNanMarker = 1.2345e307, kPosMarker = 1.2346e307, kNegMarker = 1.2347e307;
std::string ReplaceNonFiniteWords(std::string_view line) {
  static const std::regex negative(R"(-Infinity(?=\s*[,\]\}]))");
  static const std::regex positive(R"(Infinity(?=\s*[,\]\}]))");
  static const std::regex nan(R"(NaN(?=\s*[,\]\}]))");
  std::string out = std::regex_replace(std::string(line), negative, "1.2347e307");
  out = std::regex_replace(out, positive, "1.2346e307");
  return std::regex_replace(out, nan, "1.2345e307");
}

double ActionValue(const json& v, bool markers) {
  if (v.is_null()) return std::numeric_limits<double>::quiet_NaN();
  if (!v.is_number()) throw Error("action values must be numbers, got " + v.dump());
  const double d = v.get<double>();
  if (markers && d == kNanMarker) return std::numeric_limits<double>::quiet_NaN();
  if (markers && d == kPosMarker) return std::numeric_limits<double>::infinity();
  if (markers && d == kNegMarker) return -std::numeric_limits<double>::infinity();
  return d;
}

int64_t OptionalInt(const json& j, const char* key) {
  const auto it = j.find(key);
  if (it == j.end()) return -1;
  if (!it->is_number_integer()) throw Error(std::string("'") + key + "' must be an integer");
  return it->get<int64_t>();
}

}  // namespace

std::string HelloHeader(int action_dim, int height, int width) {
  return Line(
      {{"type", "hello"},
       {"protocol", kProtocolName},
       {"version", kProtocolVersion},
       {"action_dim", action_dim},
       {"image", {{"height", height}, {"width", width}, {"channels", 3}, {"encoding", "rgb8"}}}});
}

std::string ResetHeader(int64_t episode, uint64_t seed, const std::string& instruction) {
  return Line(
      {{"type", "reset"}, {"episode", episode}, {"seed", seed}, {"instruction", instruction}});
}

std::string StepHeader(const Observation& o) {
  const int64_t bytes = int64_t{o.height} * o.width * 3;
  return Line({{"type", "step"},
               {"episode", o.episode},
               {"step", o.step},
               {"instruction", o.instruction},
               {"image",
                {{"height", o.height},
                 {"width", o.width},
                 {"channels", 3},
                 {"encoding", "rgb8"},
                 {"bytes", bytes}}}});
}

std::string CloseHeader() { return Line({{"type", "close"}}); }

Reply ParseReply(std::string_view line) {
  bool markers = false;
  json j = json::parse(line, nullptr, /*allow_exceptions=*/false);
  if (j.is_discarded()) {
    j = json::parse(ReplaceNonFiniteWords(line), nullptr, false);
    markers = true;
  }
  if (j.is_discarded()) throw Error("answered a line that is not JSON: " + Quote(line));
  if (!j.is_object() || !j.contains("type") || !j["type"].is_string()) {
    throw Error("answered JSON without a string 'type': " + Quote(line));
  }
  Reply r;
  r.type = j["type"].get<std::string>();
  try {
    r.episode = OptionalInt(j, "episode");
    r.step = OptionalInt(j, "step");
    if (r.type == "error") {
      r.message = j.value("message", std::string("(no message)"));
    } else if (r.type == "hello") {
      r.protocol = j.value("protocol", std::string());
      r.version = OptionalInt(j, "version");
      r.self_description =
          json{{"name", j.value("name", json())}, {"info", j.value("info", json())}}.dump();
    } else if (r.type == "action") {
      const auto it = j.find("action");
      if (it == j.end() || !it->is_array()) throw Error("an action reply needs an 'action' array");
      for (const json& v : *it) r.action.push_back(ActionValue(v, markers));
      r.has_action = true;
    } else if (r.type != "ready") {
      throw Error("unknown reply type '" + r.type + "'");
    }
  } catch (const Error& e) {
    throw Error("answered a malformed " + r.type + " reply (" + e.message() + "): " + Quote(line));
  } catch (const json::exception& e) {
    throw Error("answered a malformed " + r.type + " reply (" + e.what() + "): " + Quote(line));
  }
  return r;
}

std::vector<float> CheckedAction(const Reply& reply, int action_dim) {
  Check(reply.type == "action", "answered a '" + reply.type + "' reply to a step, not an action");
  Check(static_cast<int>(reply.action.size()) == action_dim,
        "answered an action of width " + std::to_string(reply.action.size()) + ", expected " +
            std::to_string(action_dim) + " (the dataset's action width)");
  std::vector<float> out;
  for (size_t i = 0; i < reply.action.size(); ++i) {
    const double v = reply.action[i];
    const bool fits = std::isfinite(v) && std::abs(v) <= std::numeric_limits<float>::max();
    Check(fits, "answered a non-finite action value " +
                    std::string(std::isnan(v) ? "NaN"
                                : v > 0       ? "+inf"
                                              : "-inf") +
                    " at index " + std::to_string(i));
    out.push_back(static_cast<float>(v));
  }
  return out;
}

}  // namespace wm::policy

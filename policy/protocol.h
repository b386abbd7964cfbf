#pragma once
// The messages of the wmkit-policy protocol v1 (docs/policy-protocol.md, schema
// schemas/policy-protocol.schema.json). Each message is one line of JSON ending in '\n'; a step
// message is followed by exactly image.bytes raw RGB bytes. Building and parsing only: the
// process that carries them is policy_process.h.
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

namespace wm::policy {

inline constexpr const char* kProtocolName = "wmkit-policy";
inline constexpr int kProtocolVersion = 1;
// A reply line longer than this is refused (a policy printing binary data to stdout).
inline constexpr size_t kMaxLineBytes = 1 << 20;

// What the policy sees at one step.
struct Observation {
  const uint8_t* rgb = nullptr;  // [height, width, 3] row-major RGB, 8 bits per channel
  int height = 0, width = 0;
  std::string instruction;  // the task in words, e.g. "push the red block to the green goal"
  int64_t episode = 0;      // the id Reset() opened
  int64_t step = 0;         // 0 for the episode's first observation
};

std::string HelloHeader(int action_dim, int height, int width);
std::string ResetHeader(int64_t episode, uint64_t seed, const std::string& instruction);
// The header line of a step; the image's height * width * 3 bytes follow it.
std::string StepHeader(const Observation& observation);
std::string CloseHeader();

// One reply of the policy, parsed but not yet checked against the request.
struct Reply {
  std::string type;     // "hello", "ready", "action" or "error"
  std::string message;  // of an error reply
  // Of an action reply. Non-finite values are kept (NaN, Infinity, -Infinity and null parse
  // to NaN / +-inf) so that the check can name them.
  std::vector<double> action;
  bool has_action = false;
  int64_t episode = -1, step = -1;  // echoed by action / ready replies; -1 when absent
  std::string protocol;             // of a hello reply
  int64_t version = -1;             // of a hello reply
  std::string self_description;     // a hello reply's "name" and "info", as JSON text
};

// Parses one reply line (without its '\n'). Throws wm::Error saying what is malformed (quoting
// the line's start); the caller adds which policy, episode and step.
Reply ParseReply(std::string_view line);

// The action of an action reply as floats: throws wm::Error when the reply is not an action,
// when its width is not `action_dim` or when a value is not finite (naming the index).
std::vector<float> CheckedAction(const Reply& reply, int action_dim);

}  // namespace wm::policy

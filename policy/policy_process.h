#pragma once
// A policy that runs as a separate process (any language) and speaks the wmkit-policy protocol
// v1 on its stdin/stdout (docs/policy-protocol.md): per step wmkit sends the observation (RGB
// image, instruction, episode, step) and the policy answers an action of the dataset's width.
//
// Every failure of the policy (it crashes or exits, does not answer within the timeout, answers
// malformed JSON, an action of the wrong width or with a non-finite value, or reports an error
// itself) throws wm::Error naming the policy, the episode and the step, with the end of the
// policy's stderr; the process is killed and the object refuses further calls.
#include <sys/types.h>

#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "policy/protocol.h"

namespace wm::policy {

struct PolicyProcessOptions {
  std::string name;      // shown in every error: the policy's name in reports ("colour_noise0")
  std::string command;   // run by /bin/sh -c in the caller's working directory
  int action_dim = 7;    // values every action must have (the dataset's action width)
  int image_height = 0;  // every observation's size, pixels (RGB, 3 channels, 8 bits)
  int image_width = 0;
  double start_timeout_s = 60;  // for the hello answer: a large policy may load weights first
  double step_timeout_s = 30;   // for each reset and step answer
  // Throws wm::Error(key "--policy") naming the bad field.
  void Check() const;
};

class PolicyProcess {
 public:
  // Starts the command and exchanges hello messages (version check).
  explicit PolicyProcess(PolicyProcessOptions options);
  // Asks the policy to exit (close), waits up to 2 s, then kills what is left of it.
  ~PolicyProcess();
  PolicyProcess(const PolicyProcess&) = delete;
  PolicyProcess& operator=(const PolicyProcess&) = delete;

  // Starts (or restarts) episode `episode`. A policy that samples seeds its generator with
  // `seed`, so a run is reproducible. Episodes may interleave: several can be open at once.
  void Reset(int64_t episode, uint64_t seed, const std::string& instruction);
  // The action for one observation: `rgb` is [image_height, image_width, 3] row-major RGB.
  // Exactly action_dim finite values.
  std::vector<float> Act(const Observation& observation);
  // Ends the process (close message, then a kill after 2 s). Idempotent.
  void Close();

  const std::string& name() const { return options_.name; }
  // What the policy's hello said about itself (its "name" and "info" fields), as JSON text.
  const std::string& self_description() const { return self_description_; }

 private:
  struct Where {
    int64_t episode = -1, step = -1;  // -1: not within an episode / step
  };
  Reply Exchange(const std::string& header, const uint8_t* payload, size_t payload_bytes,
                 double timeout_s, const Where& where);
  void SendAll(const char* data, size_t size, std::chrono::steady_clock::time_point deadline,
               const Where& where);
  std::string ReadLine(std::chrono::steady_clock::time_point deadline, const Where& where);
  void DrainStderr();
  [[noreturn]] void Fail(const std::string& problem, const Where& where);
  [[noreturn]] void FailDead(const Where& where);
  void Kill();

  PolicyProcessOptions options_;
  pid_t pid_ = -1;      // process group leader (the shell)
  int io_fd_ = -1;      // socket: the policy's stdin and stdout
  int stderr_fd_ = -1;  // pipe: the policy's stderr, kept as a tail for error messages
  std::string read_buffer_;
  std::string stderr_tail_;
  std::string self_description_;
  bool broken_ = false;  // after a failure: the process is gone, calls throw
};

}  // namespace wm::policy

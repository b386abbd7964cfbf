#pragma once
// Runs work that a damaged input can crash, make allocate without bound or make loop forever
// (libhdf5 on a damaged file: docs/failure-modes.md) in a forked child process under memory and
// CPU-time limits, so that the caller gets an error it can report (or skip) instead of dying.
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

namespace wm {

struct ChildLimits {
  uint64_t memory_mb = 0;    // address space the child may add to what it inherits; 0 = none
  uint32_t cpu_seconds = 0;  // CPU time the child may use; 0 = none
};

struct ChildOutcome {
  std::optional<std::string> output;  // what `work` returned, when it returned
  std::string failure;                // otherwise why the child ended, e.g. "crashed (SIGSEGV)"
};

// Forks; the child runs `work` and sends its result back through a pipe. A wm::Error thrown by
// `work` is rethrown here with its message and context, and another exception as a wm::Error
// with its what(). The child inherits the caller's memory (copy-on-write) but only the calling
// thread, so `work` must not wait on a lock another thread may hold at the fork; it must not
// write to shared state either, as nothing it changes reaches the caller. Safe to call from
// several threads at once.
ChildOutcome RunInChildProcess(const std::function<std::string()>& work, const ChildLimits& limits);

}  // namespace wm

#include "core/child_process.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <new>
#include <optional>
#include <tuple>
#include <utility>

#include "core/byte_fields.h"
#include "core/error.h"

namespace wm {
namespace {

// The first byte the child sends says what follows.
enum Tag : char { kResult = 'R', kWmError = 'E', kOtherError = 'X', kOutOfMemory = 'M' };

// ASan's allocator (GCC 12's libsanitizer) takes no lock around fork(): when another thread
// holds it at the fork, the child's first malloc waits forever, using no CPU, so RLIMIT_CPU never
// ends it (seen in `make test-sanitize`: the child stuck in H5FL_reg_malloc). Under ASan only,
// such a child is ended by SIGALRM after kAsanForkWatchdogSeconds and the work is run again.
#if defined(__SANITIZE_ADDRESS__)
constexpr unsigned kAsanForkWatchdogSeconds = 60;
constexpr int kAsanForkAttempts = 3;
#else
constexpr unsigned kAsanForkWatchdogSeconds = 0;
constexpr int kAsanForkAttempts = 1;
#endif

void WriteAll(int fd, const char* data, size_t size) {
  while (size > 0) {
    const ssize_t n = write(fd, data, size);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return;  // the parent is gone: nothing to report to
    data += n;
    size -= static_cast<size_t>(n);
  }
}

// Reads up to `size` bytes; fewer only when the writer is gone.
size_t ReadFull(int fd, char* out, size_t size) {
  size_t got = 0;
  while (got < size) {
    const ssize_t n = read(fd, out + got, size - got);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) break;
    got += static_cast<size_t>(n);
  }
  return got;
}

// The child's message: a tag, the body's size and the body; nullopt when it is cut short (the
// child died while writing, or before).
std::optional<std::pair<char, std::string>> ReadMessage(int fd) {
  char tag = 0;
  uint64_t size = 0;
  if (ReadFull(fd, &tag, 1) != 1 ||
      ReadFull(fd, reinterpret_cast<char*>(&size), sizeof(size)) != sizeof(size)) {
    return std::nullopt;
  }
  std::string body(size, '\0');  // sized up front: no regrowth copies of a demo's MBs
  if (ReadFull(fd, body.data(), size) != size) return std::nullopt;
  return std::make_pair(tag, std::move(body));
}

// Private writable memory (data, heap, anonymous mappings) in use: what RLIMIT_DATA counts.
uint64_t DataBytes() {
  unsigned long long pages = 0;
  if (FILE* f = std::fopen("/proc/self/statm", "r")) {
    if (std::fscanf(f, "%*u %*u %*u %*u %*u %llu", &pages) != 1) pages = 0;
    std::fclose(f);
  }
  return pages * static_cast<uint64_t>(sysconf(_SC_PAGESIZE));
}

void SetLimit(int resource, uint64_t soft, uint64_t hard) {
  struct rlimit limit {};
  limit.rlim_cur = soft;
  limit.rlim_max = hard;
  setrlimit(resource, &limit);
}

[[noreturn]] void RunChild(int fd, const std::function<std::string()>& work,
                           const ChildLimits& limits) {
  // Keep only the result pipe: a sibling thread's pipe must reach EOF when its own child ends,
  // not when this one does.
  if (fd > 3) close_range(3, static_cast<unsigned>(fd) - 1, 0);
  close_range(static_cast<unsigned>(fd) + 1, ~0U, 0);
  // The parent learns of a crash from the wait status; no handler (a sanitizer's, a tool's)
  // should turn it into an exit code, and no core file is wanted.
  for (int sig : {SIGSEGV, SIGBUS, SIGFPE, SIGILL, SIGABRT, SIGXCPU}) signal(sig, SIG_DFL);
  SetLimit(RLIMIT_CORE, 0, 0);
  // RLIMIT_DATA rather than RLIMIT_AS: ASan allocates inside address space it reserved at
  // start-up, which RLIMIT_AS never sees, but the pages it makes writable count as data.
  if (limits.memory_mb > 0) {
    const uint64_t bytes = DataBytes() + (limits.memory_mb << 20);
    SetLimit(RLIMIT_DATA, bytes, bytes);
  }
  // SIGXCPU at the soft limit ends the child; the hard limit's SIGKILL is the backstop.
  if (limits.cpu_seconds > 0) SetLimit(RLIMIT_CPU, limits.cpu_seconds, limits.cpu_seconds + 1);
  if (kAsanForkWatchdogSeconds > 0) {
    signal(SIGALRM, SIG_DFL);
    alarm(kAsanForkWatchdogSeconds);
  }
  char tag = kResult;
  std::string body;
  try {
    body = work();
  } catch (const Error& e) {
    tag = kWmError;
    const ErrorContext& c = e.context();
    body.clear();
    for (std::string_view field : {std::string_view(e.message()), std::string_view(c.file),
                                   std::string_view(c.record_label), std::string_view(c.key)}) {
      bytes::Put(body, field);
    }
    bytes::Put(body, int64_t{c.record.has_value()});
    bytes::Put(body, c.record.value_or(0));
  } catch (const std::bad_alloc&) {
    tag = kOutOfMemory;
  } catch (const std::exception& e) {
    tag = kOtherError;
    body = e.what();
  } catch (...) {  // the child must never return into the caller's code
    tag = kOtherError;
    body = "an exception that is not a std::exception";
  }
  const uint64_t size = body.size();
  WriteAll(fd, &tag, 1);
  WriteAll(fd, reinterpret_cast<const char*>(&size), sizeof(size));
  WriteAll(fd, body.data(), body.size());
  _exit(0);  // no atexit handlers or static destructors: they belong to the parent
}

[[noreturn]] void RethrowChildError(const std::string& body) {
  bytes::Reader reader(body);
  std::string message;
  ErrorContext c;
  int64_t has_record = 0, record = 0;
  reader.Take(message);
  reader.Take(c.file);
  reader.Take(c.record_label);
  reader.Take(c.key);
  reader.Take(has_record);
  reader.Take(record);
  if (has_record) c.record = record;
  throw Error(message, c);
}

std::string DescribeDeath(int status, const ChildLimits& limits) {
  if (WIFSIGNALED(status)) {
    const int sig = WTERMSIG(status);
    if (limits.cpu_seconds > 0 && (sig == SIGXCPU || sig == SIGKILL)) {
      return "did not finish within its limit of " + std::to_string(limits.cpu_seconds) +
             " s of CPU time";
    }
    const char* name = sigabbrev_np(sig);
    return "crashed (SIG" + std::string(name ? name : std::to_string(sig)) + ")";
  }
  return "exited with status " + std::to_string(WEXITSTATUS(status)) + " without a result";
}

// One fork of RunInChildProcess: the child's message (if any) and its wait status.
std::pair<std::optional<std::pair<char, std::string>>, int> ForkOnce(
    const std::function<std::string()>& work, const ChildLimits& limits) {
  int fds[2];
  Check(pipe2(fds, O_CLOEXEC) == 0, std::string("cannot create a pipe: ") + std::strerror(errno));
  fcntl(fds[0], F_SETPIPE_SZ, 1 << 20);  // fewer wake-ups for a demo's MBs; best effort
  const pid_t pid = fork();
  if (pid < 0) {
    const int err = errno;
    close(fds[0]);
    close(fds[1]);
    throw Error(std::string("cannot fork a child process: ") + std::strerror(err));
  }
  if (pid == 0) {
    close(fds[0]);
    RunChild(fds[1], work, limits);
  }
  close(fds[1]);
  std::optional<std::pair<char, std::string>> message = ReadMessage(fds[0]);
  close(fds[0]);
  int status = 0;
  while (waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  return {std::move(message), status};
}

}  // namespace

ChildOutcome RunInChildProcess(const std::function<std::string()>& work,
                               const ChildLimits& limits) {
  auto [message, status] = ForkOnce(work, limits);
  for (int attempt = 1;
       attempt < kAsanForkAttempts && WIFSIGNALED(status) && WTERMSIG(status) == SIGALRM;
       ++attempt) {
    std::tie(message, status) = ForkOnce(work, limits);
  }
  const bool returned = WIFEXITED(status) && WEXITSTATUS(status) == 0 && message;
  if (!returned) return {std::nullopt, DescribeDeath(status, limits)};
  std::string& body = message->second;
  switch (message->first) {
    case kResult:
      return {std::move(body), ""};
    case kWmError:
      RethrowChildError(body);
    case kOutOfMemory:
      return {std::nullopt, limits.memory_mb == 0 ? std::string("ran out of memory")
                                                  : "ran out of its memory limit of " +
                                                        std::to_string(limits.memory_mb) + " MB"};
    default:
      throw Error(body);
  }
}

}  // namespace wm

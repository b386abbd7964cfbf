#include "policy/policy_process.h"

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <thread>

#include "core/error.h"

namespace wm::policy {
namespace {

using Clock = std::chrono::steady_clock;
constexpr size_t kStderrTailBytes = 1000;

Clock::time_point DeadlineIn(double seconds) {
  return Clock::now() +
         std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(seconds));
}

int MillisecondsLeft(Clock::time_point deadline) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now());
  return static_cast<int>(std::max<int64_t>(0, left.count()));
}

std::string Seconds(double s) {
  char text[32];
  std::snprintf(text, sizeof(text), "%g", s);
  return text;
}

[[noreturn]] void ExecChild(const std::string& command, int io_fd, int stderr_fd) {
  setpgid(0, 0);  // its own group: a timeout kills the shell and whatever it started
  dup2(io_fd, STDIN_FILENO);
  dup2(io_fd, STDOUT_FILENO);
  dup2(stderr_fd, STDERR_FILENO);
  close_range(3, ~0U, 0);
  // exec keeps ignored signals ignored; a policy should die of a broken pipe like any program.
  signal(SIGPIPE, SIG_DFL);
  sigset_t none;
  sigemptyset(&none);
  sigprocmask(SIG_SETMASK, &none, nullptr);
  execl("/bin/sh", "sh", "-c", command.c_str(), static_cast<char*>(nullptr));
  _exit(127);
}

std::string DescribeStatus(int status) {
  if (WIFSIGNALED(status)) {
    const char* name = sigabbrev_np(WTERMSIG(status));
    return "was killed by SIG" + std::string(name ? name : std::to_string(WTERMSIG(status)));
  }
  const int code = WEXITSTATUS(status);
  if (code == 127) return "exited with status 127 (command not found?)";
  // The shell reports a command killed by signal N as status 128 + N.
  const char* name = code > 128 && code < 128 + 65 ? sigabbrev_np(code - 128) : nullptr;
  if (name) return "exited with status " + std::to_string(code) + " (killed by SIG" + name + ")";
  return "exited with status " + std::to_string(code);
}

}  // namespace

void PolicyProcessOptions::Check() const {
  wm::Check(!name.empty(), "a policy needs a name", {.key = "--policy"});
  wm::Check(!command.empty(), "policy '" + name + "' has an empty command", {.key = "--policy"});
  wm::Check(action_dim >= 1 && action_dim <= 4096, "action width must be in 1..4096",
            {.key = "--policy"});
  wm::Check(image_height >= 1 && image_width >= 1 && image_height <= 8192 && image_width <= 8192,
            "image size must be in 1..8192 pixels", {.key = "--policy"});
  wm::Check(start_timeout_s > 0 && step_timeout_s > 0, "timeouts must be positive",
            {.key = "--policy-timeout"});
}

PolicyProcess::PolicyProcess(PolicyProcessOptions options) : options_(std::move(options)) {
  options_.Check();
  int io[2], err[2];
  Check(socketpair(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0, io) == 0,
        "cannot create a socket pair for policy '" + options_.name + "': " + std::strerror(errno));
  if (pipe2(err, O_CLOEXEC) != 0) {
    close(io[0]), close(io[1]);
    throw Error("cannot create a pipe for policy '" + options_.name + "': " + std::strerror(errno));
  }
  pid_ = fork();
  if (pid_ == 0) ExecChild(options_.command, io[1], err[1]);
  const int fork_errno = errno;
  close(io[1]), close(err[1]);
  io_fd_ = io[0], stderr_fd_ = err[0];
  if (pid_ < 0) {
    Kill();
    throw Error("cannot start policy '" + options_.name + "': " + std::strerror(fork_errno));
  }
  setpgid(pid_, pid_);  // also here, so that a kill right after fork reaches the group
  fcntl(io_fd_, F_SETFL, fcntl(io_fd_, F_GETFL) | O_NONBLOCK);
  fcntl(stderr_fd_, F_SETFL, fcntl(stderr_fd_, F_GETFL) | O_NONBLOCK);
  const Reply hello =
      Exchange(HelloHeader(options_.action_dim, options_.image_height, options_.image_width),
               nullptr, 0, options_.start_timeout_s, {});
  if (hello.type != "hello") Fail("answered '" + hello.type + "' to hello", {});
  if (hello.protocol != kProtocolName || hello.version != kProtocolVersion) {
    Fail("speaks protocol '" + hello.protocol + "' version " + std::to_string(hello.version) +
             ", wmkit speaks '" + kProtocolName + "' version " + std::to_string(kProtocolVersion),
         {});
  }
  self_description_ = hello.self_description;
}

PolicyProcess::~PolicyProcess() {
  try {
    Close();
  } catch (...) {  // a destructor must not throw; Close() only fails on a broken system
  }
}

void PolicyProcess::Reset(int64_t episode, uint64_t seed, const std::string& instruction) {
  const Where where{episode, -1};
  const Reply r =
      Exchange(ResetHeader(episode, seed, instruction), nullptr, 0, options_.step_timeout_s, where);
  if (r.type != "ready") Fail("answered '" + r.type + "' to reset, expected 'ready'", where);
}

std::vector<float> PolicyProcess::Act(const Observation& o) {
  const Where where{o.episode, o.step};
  if (o.height != options_.image_height || o.width != options_.image_width || !o.rgb) {
    throw Error("policy '" + options_.name + "' was started for " +
                std::to_string(options_.image_width) + "x" + std::to_string(options_.image_height) +
                " images, not " + std::to_string(o.width) + "x" + std::to_string(o.height));
  }
  const Reply r = Exchange(StepHeader(o), o.rgb, size_t{3} * o.height * o.width,
                           options_.step_timeout_s, where);
  if ((r.episode >= 0 && r.episode != o.episode) || (r.step >= 0 && r.step != o.step)) {
    Fail("answered for episode " + std::to_string(r.episode) + ", step " + std::to_string(r.step),
         where);
  }
  try {
    return CheckedAction(r, options_.action_dim);
  } catch (const Error& e) {
    Fail(e.message(), where);
  }
}

void PolicyProcess::Close() {
  if (pid_ < 0) return;
  if (!broken_) {
    const std::string close_line = CloseHeader();
    send(io_fd_, close_line.data(), close_line.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    shutdown(io_fd_, SHUT_WR);  // EOF on its stdin: the other way to say close
    const auto deadline = DeadlineIn(2.0);
    int status = 0;
    while (Clock::now() < deadline) {
      if (waitpid(pid_, &status, WNOHANG) == pid_) {
        kill(-pid_, SIGKILL);  // whatever the shell left behind
        pid_ = -1;
        break;
      }
      DrainStderr();
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  }
  Kill();
}

void PolicyProcess::Kill() {
  if (pid_ > 0) {
    kill(-pid_, SIGKILL);
    kill(pid_, SIGKILL);
    while (waitpid(pid_, nullptr, 0) < 0 && errno == EINTR) {
    }
    pid_ = -1;
  }
  if (io_fd_ >= 0) close(io_fd_), io_fd_ = -1;
  if (stderr_fd_ >= 0) close(stderr_fd_), stderr_fd_ = -1;
  broken_ = true;
}

Reply PolicyProcess::Exchange(const std::string& header, const uint8_t* payload,
                              size_t payload_bytes, double timeout_s, const Where& where) {
  if (broken_) Fail("is no longer running (it failed before)", where);
  const auto deadline = DeadlineIn(timeout_s);
  SendAll(header.data(), header.size(), deadline, where);
  if (payload_bytes > 0) {
    SendAll(reinterpret_cast<const char*>(payload), payload_bytes, deadline, where);
  }
  const std::string line = ReadLine(deadline, where);
  Reply reply;
  try {
    reply = ParseReply(line);
  } catch (const Error& e) {
    Fail(e.message(), where);
  }
  if (reply.type == "error") Fail("reported an error: " + reply.message, where);
  return reply;
}

void PolicyProcess::SendAll(const char* data, size_t size, Clock::time_point deadline,
                            const Where& where) {
  while (size > 0) {
    const ssize_t n = send(io_fd_, data, size, MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      data += n, size -= static_cast<size_t>(n);
      continue;
    }
    if (n < 0 && errno == EINTR) continue;
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK) FailDead(where);  // EPIPE, ECONNRESET
    pollfd fds[2] = {{io_fd_, POLLOUT, 0}, {stderr_fd_, POLLIN, 0}};
    if (Clock::now() >= deadline) {
      Fail("did not read its input within " + Seconds(options_.step_timeout_s) + " s", where);
    }
    poll(fds, 2, MillisecondsLeft(deadline));
    if (fds[1].revents) DrainStderr();
  }
}

std::string PolicyProcess::ReadLine(Clock::time_point deadline, const Where& where) {
  for (;;) {
    const size_t end = read_buffer_.find('\n');
    if (end != std::string::npos) {
      std::string line = read_buffer_.substr(0, end);
      read_buffer_.erase(0, end + 1);
      if (!line.empty() && line.back() == '\r') line.pop_back();
      return line;
    }
    if (read_buffer_.size() > kMaxLineBytes) {
      Fail("wrote more than " + std::to_string(kMaxLineBytes) +
               " bytes to stdout without a newline (does it print to stdout?)",
           where);
    }
    const int left = MillisecondsLeft(deadline);
    if (left <= 0) {
      const double limit = where.episode < 0 && where.step < 0 && self_description_.empty()
                               ? options_.start_timeout_s
                               : options_.step_timeout_s;
      Fail("did not answer within " + Seconds(limit) + " s (hung? raise --policy-timeout)", where);
    }
    pollfd fds[2] = {{io_fd_, POLLIN, 0}, {stderr_fd_, POLLIN, 0}};
    if (poll(fds, 2, left) < 0 && errno != EINTR) Fail("poll failed", where);
    if (fds[1].revents) DrainStderr();
    if (fds[0].revents) {
      char chunk[65536];
      const ssize_t n = read(io_fd_, chunk, sizeof(chunk));
      if (n > 0) {
        read_buffer_.append(chunk, static_cast<size_t>(n));
      } else if (n == 0 || (errno != EAGAIN && errno != EINTR)) {
        FailDead(where);
      }
    }
  }
}

void PolicyProcess::DrainStderr() {
  if (stderr_fd_ < 0) return;
  char chunk[4096];
  for (;;) {
    const ssize_t n = read(stderr_fd_, chunk, sizeof(chunk));
    if (n <= 0) return;
    stderr_tail_.append(chunk, static_cast<size_t>(n));
    if (stderr_tail_.size() > 2 * kStderrTailBytes) {
      stderr_tail_.erase(0, stderr_tail_.size() - kStderrTailBytes);
    }
  }
}

void PolicyProcess::FailDead(const Where& where) {
  // Its stdout closed: wait briefly for the exit status (and the last of its stderr).
  std::string how = "closed its stdout";
  const auto deadline = DeadlineIn(1.0);
  while (pid_ > 0 && Clock::now() < deadline) {
    int status = 0;
    if (waitpid(pid_, &status, WNOHANG) == pid_) {
      how = DescribeStatus(status);
      kill(-pid_, SIGKILL);
      pid_ = -1;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  Fail(how + " without answering", where);
}

void PolicyProcess::Fail(const std::string& problem, const Where& where) {
  DrainStderr();
  Kill();
  std::string at;
  if (where.episode >= 0) at += ", episode " + std::to_string(where.episode);
  if (where.step >= 0) at += ", step " + std::to_string(where.step);
  if (at.empty()) at = ", at start-up";
  std::string message = "policy '" + options_.name + "'" + at + ": " + problem;
  std::string tail = stderr_tail_.size() > kStderrTailBytes
                         ? stderr_tail_.substr(stderr_tail_.size() - kStderrTailBytes)
                         : stderr_tail_;
  while (!tail.empty() && (tail.back() == '\n' || tail.back() == ' ')) tail.pop_back();
  if (!tail.empty()) {
    for (char& c : tail) c = c == '\n' ? '|' : c;  // one line, as every wmkit error
    message += " [its stderr ends: " + tail + "]";
  }
  throw Error(message);
}

}  // namespace wm::policy

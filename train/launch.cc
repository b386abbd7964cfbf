#include "train/launch.h"

#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <iostream>
#include <string>
#include <vector>

#include "core/error.h"
#include "train/distributed.h"

extern char** environ;

namespace wm::train {
namespace {

int EnvInt(const char* name, int fallback, int min_value) {
  const char* v = std::getenv(name);
  if (v == nullptr || *v == '\0') return fallback;
  char* end = nullptr;
  const long x = std::strtol(v, &end, 10);
  Check(*end == '\0' && x >= min_value && x <= 1 << 20,
        std::string("environment variable has a bad value '") + v + "'", {.key = name});
  return static_cast<int>(x);
}

}  // namespace

void ReadDistributedEnvironment(TrainOptions& o) {
  const int named_world = EnvInt("WORLD_SIZE", 0, 1);  // 0: no launcher named one
  o.launched = named_world > 0;
  o.world_size = o.launched ? named_world : 1;
  o.rank = EnvInt("RANK", 0, 0);
  Check(o.rank < o.world_size, "RANK must be < WORLD_SIZE", {.key = "RANK"});
  if (const char* addr = std::getenv("MASTER_ADDR"); addr != nullptr && *addr != '\0') {
    o.master_addr = addr;
  }
  o.master_port = EnvInt("MASTER_PORT", 29500, 1);
  if (o.rank != 0) o.show_progress = false;
  // One GPU per process on a node, as torchrun sets it up: a bare "cuda" is cuda:LOCAL_RANK.
  if (const int local = EnvInt("LOCAL_RANK", -1, 0); o.device == "cuda" && local >= 0) {
    o.device = "cuda:" + std::to_string(local);
  }
}

int SpawnLocalRanks(int nproc, int argc, char** argv) {
  std::vector<std::string> args;
  for (int i = 0; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--nproc") {
      ++i;  // and its value
    } else if (a.rfind("--nproc=", 0) != 0) {
      args.push_back(a);
    }
  }
  std::vector<char*> child_argv;
  for (auto& a : args) child_argv.push_back(a.data());
  child_argv.push_back(nullptr);
  const std::string port = std::to_string(FindFreePort());
  std::vector<pid_t> pids;
  for (int rank = 0; rank < nproc; ++rank) {
    std::vector<std::string> env_strings;
    for (char** e = environ; *e != nullptr; ++e) {
      const std::string kv = *e;
      const std::string key = kv.substr(0, kv.find('='));
      if (key != "RANK" && key != "WORLD_SIZE" && key != "LOCAL_RANK" && key != "MASTER_ADDR" &&
          key != "MASTER_PORT") {
        env_strings.push_back(kv);
      }
    }
    env_strings.push_back("RANK=" + std::to_string(rank));
    env_strings.push_back("LOCAL_RANK=" + std::to_string(rank));
    env_strings.push_back("WORLD_SIZE=" + std::to_string(nproc));
    env_strings.push_back("MASTER_ADDR=127.0.0.1");
    env_strings.push_back("MASTER_PORT=" + port);
    std::vector<char*> env;
    for (auto& s : env_strings) env.push_back(s.data());
    env.push_back(nullptr);
    pid_t pid = 0;
    const int rc =
        posix_spawn(&pid, "/proc/self/exe", nullptr, nullptr, child_argv.data(), env.data());
    Check(rc == 0, "cannot start rank " + std::to_string(rank) + ": " + std::strerror(rc));
    pids.push_back(pid);
  }
  int failed = 0;
  std::vector<bool> alive(pids.size(), true);
  for (size_t done = 0; done < pids.size(); ++done) {
    int status = 0;
    const pid_t pid = ::wait(&status);
    if (pid < 0) break;
    for (size_t r = 0; r < pids.size(); ++r) {
      if (pids[r] == pid) alive[r] = false;
    }
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      if (failed == 0) {
        for (size_t r = 0; r < pids.size(); ++r) {
          if (pids[r] == pid) std::cerr << "wm-train: error: rank " << r << " failed\n";
        }
      }
      ++failed;
      // The others would wait for the failed rank's gradients until the store times out.
      for (size_t r = 0; r < pids.size(); ++r) {
        if (alive[r]) ::kill(pids[r], SIGTERM);
      }
    }
  }
  return failed == 0 ? 0 : 1;
}

}  // namespace wm::train

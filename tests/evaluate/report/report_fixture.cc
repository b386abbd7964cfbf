#include "report_fixture.h"

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>

namespace wm::test {
namespace {

std::string G9(double v) {
  if (!std::isfinite(v)) return "";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.9g", v);
  return buffer;
}

}  // namespace

std::string FakePolicy(int episode) { return episode % 2 ? "noisy" : "expert"; }

void WriteText(const std::string& path, const std::string& text) {
  std::ofstream(path, std::ios::binary) << text;
}

std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

std::string WriteFakeReport(const std::string& root, const FakeReport& r) {
  const std::string dir = (std::filesystem::path(root) / r.name).string();
  std::filesystem::create_directories(dir);
  WriteText(dir + "/manifest.json",
            R"({"checkpoint": {"name": ")" + r.name + R"(", "sha256": ")" + std::string(64, 'a') +
                R"(", "step": 10}, "config_hash": "c0ffee", "seed": 0, "git_commit": "abc",)" +
                R"( "tool": "wm-eval", "data": {"split": "val"}})");
  std::string summary = "checkpoint,rollout,metric,mean,ci_low,ci_high,n\n";
  std::string per_episode = "checkpoint,rollout,episode,policy_id,metric,value\n";
  for (const auto& [rollout, metrics] : r.episodes) {
    for (const auto& [metric, values] : metrics) {
      double sum = 0;
      int n = 0;
      for (size_t k = 0; k < values.size(); ++k) {
        const int episode = r.first_episode + static_cast<int>(k);
        per_episode += r.name + "," + rollout + "," + std::to_string(episode) + "," +
                       FakePolicy(episode) + "," + metric + "," + G9(values[k]) + "\n";
        if (std::isfinite(values[k])) sum += values[k], ++n;
      }
      const double mean = n ? sum / n : NAN;
      summary += r.name + "," + rollout + "," + metric + "," + G9(mean) + "," + G9(mean - 1) + "," +
                 G9(mean + 1) + "," + std::to_string(n) + "\n";
    }
  }
  for (const auto& [rollout, metrics] : r.whole_set) {
    for (const auto& [metric, value] : metrics) {
      summary += r.name + "," + rollout + "," + metric + "," + G9(value) + ",,,4\n";
    }
  }
  WriteText(dir + "/summary.csv", summary);
  WriteText(dir + "/per_episode.csv", per_episode);
  return dir;
}

}  // namespace wm::test

#pragma once
// Hand-made wm-eval report directories for the wm-report tests: summary.csv means are the means
// of the per-episode values given, so expected deltas and ranks can be worked out by hand.
#include <map>
#include <string>
#include <vector>

namespace wm::test {

struct FakeReport {
  std::string name;
  // rollout -> metric -> value of episode first_episode + k (NaN: an empty cell).
  std::map<std::string, std::map<std::string, std::vector<double>>> episodes;
  // rollout -> metric -> whole-set value (summary.csv only, like fvd_style or pearson).
  std::map<std::string, std::map<std::string, double>> whole_set;
  int first_episode = 0;
};

// The policy of episode k in every fake report.
std::string FakePolicy(int episode);

// Writes manifest.json, summary.csv and per_episode.csv of `report` into root/<name>; returns
// that directory.
std::string WriteFakeReport(const std::string& root, const FakeReport& report);

// Replaces `path`'s text.
void WriteText(const std::string& path, const std::string& text);
std::string ReadText(const std::string& path);

}  // namespace wm::test

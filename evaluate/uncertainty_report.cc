#include "evaluate/uncertainty_report.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <string_view>

#include "core/error.h"
#include "metrics/value/correlation.h"

namespace wm::evaluate {
namespace {

constexpr const char* kRollout = "plain";  // the signals describe sample 0 of the plain rollout

// The per-step values of `signal` in `rec`, or null when it has none.
const std::vector<double>* Signal(const EpisodeRecord& rec, std::string_view signal) {
  if (signal == "sample_disagreement") {
    const auto s = rec.spread.find(kRollout);
    return s == rec.spread.end() ? nullptr : &s->second;
  }
  const auto& scores = rec.scores.at(kRollout);
  const auto s = scores.find(std::string(signal));
  return s == scores.end() ? nullptr : &s->second;
}

// Correlations over (episode, step) pairs and the AUROC over episodes of one signal.
void AddSignalScores(std::map<std::string, MeanCi>& whole, const std::string& signal,
                     const std::vector<EpisodeRecord>& records) {
  std::vector<double> x, y, episode_signal, episode_error;
  for (const EpisodeRecord& rec : records) {
    const std::vector<double>& values = *Signal(rec, signal);
    const std::vector<double>& error = rec.scores.at(kRollout).at("mse");
    x.insert(x.end(), values.begin(), values.end());
    y.insert(y.end(), error.begin(), error.end());
    episode_signal.push_back(FiniteMean(values));
    episode_error.push_back(FiniteMean(error));
  }
  const auto pairs = static_cast<int64_t>(x.size());
  whole[signal + "_error_pearson"] = {metrics::Pearson(x, y), NAN, NAN, pairs};
  whole[signal + "_error_spearman"] = {metrics::Spearman(x, y), NAN, NAN, pairs};
  whole[signal + "_auroc"] = {metrics::Auroc(episode_signal, AboveMedian(episode_error)), NAN, NAN,
                              static_cast<int64_t>(records.size())};
}

}  // namespace

std::vector<bool> AboveMedian(const std::vector<double>& values) {
  if (values.empty()) return {};
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  const size_t n = sorted.size();
  const double median = n % 2 ? sorted[n / 2] : (sorted[n / 2 - 1] + sorted[n / 2]) / 2;
  std::vector<bool> out;
  out.reserve(n);
  for (double v : values) out.push_back(v > median);
  return out;
}

std::string AddUncertaintyScores(ScoreTable& t, const std::string& checkpoint,
                                 const std::vector<EpisodeRecord>& records) {
  std::string csv = "checkpoint,rollout,episode,step,mse";
  for (const char* signal : kUncertaintySignals) csv += std::string(",") + signal;
  csv += "\n";
  for (const EpisodeRecord& rec : records) {
    const std::vector<double>& error = rec.scores.at(kRollout).at("mse");
    for (size_t s = 0; s < error.size(); ++s) {
      csv += checkpoint + "," + kRollout + "," + std::to_string(rec.episode) + "," +
             std::to_string(s + 1) + "," + Cell(error[s]);
      for (const char* signal : kUncertaintySignals) {
        const std::vector<double>* values = Signal(rec, signal);
        csv += "," + (values ? Cell(values->at(s)) : std::string());
      }
      csv += "\n";
    }
  }
  for (const char* signal : kUncertaintySignals) {
    const bool everywhere = !records.empty() && std::all_of(records.begin(), records.end(),
                                                            [&](const EpisodeRecord& rec) {
                                                              return Signal(rec, signal) != nullptr;
                                                            });
    if (everywhere) AddSignalScores(t.whole_set[kRollout], signal, records);
  }
  return csv;
}

}  // namespace wm::evaluate

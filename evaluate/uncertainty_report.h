#pragma once
// The report side of wm-eval --retrace-ks (docs/reports.md, "uncertainty.csv"): per (episode,
// step) of the plain rollout, the real error (MSE of sample 0 against the true frame) beside
// each uncertainty signal; per signal, its Pearson and Spearman correlation with the error over
// the (episode, step) pairs and its AUROC for flagging the episodes whose mean error is above
// the median episode's.
#include <array>
#include <string>
#include <vector>

#include "evaluate/aggregate.h"
#include "evaluate/episode_record.h"

namespace wm::evaluate {

// retrace_disagreement and token_entropy: scores of the plain rollout (retrace_uncertainty.h);
// sample_disagreement: the --samples spread (EpisodeRecord::spread; with --samples >= 2 only).
inline constexpr std::array<const char*, 3> kUncertaintySignals = {
    "retrace_disagreement", "token_entropy", "sample_disagreement"};

// Per value: whether it is above the median of `values` (strictly; the median of an even count
// is the mean of the middle two), so ties with the median are not flagged.
std::vector<bool> AboveMedian(const std::vector<double>& values);

// Adds <signal>_error_pearson and <signal>_error_spearman (n: (episode, step) pairs) and
// <signal>_auroc (n: episodes) of every signal the records hold to t.whole_set["plain"], and
// returns uncertainty.csv (header and one row per episode and step; a signal the records lack
// is an empty cell).
std::string AddUncertaintyScores(ScoreTable& t, const std::string& checkpoint,
                                 const std::vector<EpisodeRecord>& records);

}  // namespace wm::evaluate

#pragma once
// A Comparison as compare.csv (every number "%.9g", undefined -> empty cell, so the same inputs
// give the same bytes) and as a Markdown table for pasting (4 significant digits). Columns:
// docs/reports.md, "compare.csv"; schema: schemas/report-compare.schema.json.
#include <string>
#include <vector>

#include "evaluate/report/compare.h"

namespace wm::report {

// "checkpoint", "rollout", then per metric m: m, m_ci_low, m_ci_high, m_delta, m_delta_ci_low,
// m_delta_ci_high, m_delta_significant, m_rank and, with `vs_copy_last`, m_vs_copy_last,
// m_vs_copy_last_ci_low, m_vs_copy_last_ci_high, m_beats_copy_last.
std::vector<std::string> CompareCsvHeader(const std::vector<std::string>& metrics,
                                          bool vs_copy_last = false);

std::string ComparisonToCsv(const Comparison& comparison);

// `level` is the delta intervals' coverage, named in the table's caption. With a copy_last rollout
// a second table follows: each other row against its report's copy_last.
std::string ComparisonToMarkdown(const Comparison& comparison, double level);

// "%.9g"; "" for NaN and infinity.
std::string FormatNumber(double value);

}  // namespace wm::report

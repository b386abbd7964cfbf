#include "evaluate/report/compare_format.h"

#include <cmath>
#include <cstdio>

#include "evaluate/report/metric_direction.h"
#include "metrics/value/csv_table.h"

namespace wm::report {
namespace {

std::string Format(const char* format, double value) {
  if (!std::isfinite(value)) return "";
  char buffer[40];
  std::snprintf(buffer, sizeof(buffer), format, value);
  return buffer;
}

std::string Short(double value) { return Format("%.4g", value); }

std::string Signed(double value) { return Format("%+.4g", value); }

std::string JoinRow(const std::vector<std::string>& cells, const char* separator) {
  std::string line;
  for (size_t i = 0; i < cells.size(); ++i) line += (i ? separator : "") + cells[i];
  return line;
}

// Markdown table cells cannot hold a bare '|'.
std::string MarkdownText(const std::string& text) {
  std::string out;
  for (char ch : text) out += ch == '|' ? std::string("\\|") : std::string(1, ch);
  return out;
}

std::string Interval(double low, double high, std::string (*format)(double)) {
  if (!std::isfinite(low) || !std::isfinite(high)) return "";
  return " [" + format(low) + ", " + format(high) + "]";
}

std::string ValueCell(const MetricComparison& c) {
  if (!std::isfinite(c.mean)) return "–";
  std::string cell = Short(c.mean) + Interval(c.ci_low, c.ci_high, Short);
  if (c.rank) cell += " #" + std::to_string(*c.rank);
  return c.rank == 1 ? "**" + cell + "**" : cell;
}

std::string DeltaCell(const MetricComparison& c, bool baseline) {
  if (baseline) return "baseline";
  if (!std::isfinite(c.delta)) return "–";
  std::string cell = Signed(c.delta) + Interval(c.delta_ci_low, c.delta_ci_high, Signed);
  return c.significant.value_or(false) ? cell + " *" : cell;
}

}  // namespace

std::string FormatNumber(double value) { return Format("%.9g", value); }

std::vector<std::string> CompareCsvHeader(const std::vector<std::string>& metrics) {
  std::vector<std::string> header = {"checkpoint", "rollout"};
  for (const auto& m : metrics) {
    for (const char* suffix : {"", "_ci_low", "_ci_high", "_delta", "_delta_ci_low",
                               "_delta_ci_high", "_delta_significant", "_rank"}) {
      header.push_back(m + suffix);
    }
  }
  return header;
}

std::string ComparisonToCsv(const Comparison& comparison) {
  std::string out = JoinRow(CompareCsvHeader(comparison.metrics), ",") + "\n";
  for (const auto& row : comparison.rows) {
    std::vector<std::string> cells = {metrics::CsvCell(row.checkpoint),
                                      metrics::CsvCell(row.rollout)};
    for (const auto& c : row.metrics) {
      for (double v : {c.mean, c.ci_low, c.ci_high, c.delta, c.delta_ci_low, c.delta_ci_high}) {
        cells.push_back(FormatNumber(v));
      }
      cells.push_back(c.significant ? (*c.significant ? "1" : "0") : "");
      cells.push_back(c.rank ? std::to_string(*c.rank) : "");
    }
    out += JoinRow(cells, ",") + "\n";
  }
  return out;
}

std::string ComparisonToMarkdown(const Comparison& comparison, double level) {
  const std::string percent = Format("%g", 100 * level);
  std::string out = "Baseline: `" + MarkdownText(comparison.baseline) + "`. ";
  out += "Cells: mean [bootstrap " + percent + "% CI] #rank (1 = best, bold). ";
  out += "Δ = checkpoint − baseline, paired over episodes, with its " + percent;
  out += "% paired-bootstrap CI; * = the CI excludes 0.\n\n";
  std::vector<std::string> header = {"checkpoint", "rollout"}, rule = {"---", "---"};
  for (const auto& m : comparison.metrics) {
    const bool higher = MetricDirection(m) == Direction::kHigherIsBetter;
    header.push_back(MarkdownText(m) + (higher ? " ↑" : " ↓"));
    header.push_back("Δ " + MarkdownText(m));
    rule.insert(rule.end(), {"---:", "---:"});
  }
  out += "| " + JoinRow(header, " | ") + " |\n| " + JoinRow(rule, " | ") + " |\n";
  for (const auto& row : comparison.rows) {
    std::vector<std::string> cells = {MarkdownText(row.checkpoint), MarkdownText(row.rollout)};
    for (const auto& c : row.metrics) {
      cells.push_back(ValueCell(c));
      cells.push_back(DeltaCell(c, row.baseline));
    }
    out += "| " + JoinRow(cells, " | ") + " |\n";
  }
  return out;
}

}  // namespace wm::report

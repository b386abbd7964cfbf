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

std::vector<std::string> CompareCsvHeader(const std::vector<std::string>& metrics,
                                          bool vs_copy_last) {
  std::vector<std::string> header = {"checkpoint", "rollout"};
  for (const auto& m : metrics) {
    for (const char* suffix : {"", "_ci_low", "_ci_high", "_delta", "_delta_ci_low",
                               "_delta_ci_high", "_delta_significant", "_rank"}) {
      header.push_back(m + suffix);
    }
    if (!vs_copy_last) continue;
    for (const char* suffix :
         {"_vs_copy_last", "_vs_copy_last_ci_low", "_vs_copy_last_ci_high", "_beats_copy_last"}) {
      header.push_back(m + suffix);
    }
  }
  return header;
}

std::string ComparisonToCsv(const Comparison& comparison) {
  std::string out =
      JoinRow(CompareCsvHeader(comparison.metrics, comparison.has_copy_last), ",") + "\n";
  for (const auto& row : comparison.rows) {
    std::vector<std::string> cells = {metrics::CsvCell(row.checkpoint),
                                      metrics::CsvCell(row.rollout)};
    for (const auto& c : row.metrics) {
      for (double v : {c.mean, c.ci_low, c.ci_high, c.delta, c.delta_ci_low, c.delta_ci_high}) {
        cells.push_back(FormatNumber(v));
      }
      cells.push_back(c.significant ? (*c.significant ? "1" : "0") : "");
      cells.push_back(c.rank ? std::to_string(*c.rank) : "");
      if (!comparison.has_copy_last) continue;
      for (double v : {c.vs_copy_last, c.vs_copy_last_ci_low, c.vs_copy_last_ci_high}) {
        cells.push_back(FormatNumber(v));
      }
      cells.push_back(c.beats_copy_last ? std::to_string(*c.beats_copy_last) : "");
    }
    out += JoinRow(cells, ",") + "\n";
  }
  return out;
}

namespace {

std::string MetricHeader(const std::string& metric) {
  const bool higher = MetricDirection(metric) == Direction::kHigherIsBetter;
  return MarkdownText(metric) + (higher ? " ↑" : " ↓");
}

std::string CopyLastCell(const MetricComparison& c) {
  if (!std::isfinite(c.vs_copy_last)) return "–";
  std::string cell =
      Signed(c.vs_copy_last) + Interval(c.vs_copy_last_ci_low, c.vs_copy_last_ci_high, Signed);
  if (!c.beats_copy_last) return cell;
  return cell + (*c.beats_copy_last > 0 ? " better" : *c.beats_copy_last < 0 ? " worse" : " same");
}

// Every row but copy_last's against its own report's copy_last, for the metrics that have such a
// difference somewhere; empty when none has.
std::string CopyLastTable(const Comparison& comparison, const std::string& percent) {
  std::vector<size_t> shown;
  for (size_t m = 0; m < comparison.metrics.size(); ++m) {
    for (const auto& row : comparison.rows) {
      if (std::isfinite(row.metrics[m].vs_copy_last)) {
        shown.push_back(m);
        break;
      }
    }
  }
  if (shown.empty()) return "";
  std::string out = "\nAgainst copy_last: Δ = rollout − the same report's copy_last, paired over ";
  out += "episodes, with its " + percent + "% paired-bootstrap CI; better / worse = the CI ";
  out += "excludes 0 on the metric's better / worse side (↑ higher, ↓ lower is better), same = ";
  out += "it contains 0.\n\n";
  std::vector<std::string> header = {"checkpoint", "rollout"}, rule = {"---", "---"};
  for (size_t m : shown) {
    header.push_back("Δ " + MetricHeader(comparison.metrics[m]));
    rule.push_back("---:");
  }
  out += "| " + JoinRow(header, " | ") + " |\n| " + JoinRow(rule, " | ") + " |\n";
  for (const auto& row : comparison.rows) {
    if (row.rollout == "copy_last") continue;
    std::vector<std::string> cells = {MarkdownText(row.checkpoint), MarkdownText(row.rollout)};
    for (size_t m : shown) cells.push_back(CopyLastCell(row.metrics[m]));
    out += "| " + JoinRow(cells, " | ") + " |\n";
  }
  return out;
}

}  // namespace

std::string ComparisonToMarkdown(const Comparison& comparison, double level) {
  const std::string percent = Format("%g", 100 * level);
  std::string out = "Baseline: `" + MarkdownText(comparison.baseline) + "`. ";
  out += "Cells: mean [bootstrap " + percent + "% CI] #rank (1 = best, bold). ";
  out += "Δ = checkpoint − baseline, paired over episodes, with its " + percent;
  out += "% paired-bootstrap CI; * = the CI excludes 0.\n\n";
  std::vector<std::string> header = {"checkpoint", "rollout"}, rule = {"---", "---"};
  for (const auto& m : comparison.metrics) {
    header.push_back(MetricHeader(m));
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
  return out + CopyLastTable(comparison, percent);
}

}  // namespace wm::report

#include "metrics/scaling/scaling_io.h"

#include <cmath>
#include <nlohmann/json.hpp>

#include "core/error.h"
#include "metrics/value/csv_table.h"

namespace wm::metrics {
namespace {
using nlohmann::json;

// JSON has no NaN: an undefined value is null.
json Number(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }
json Optional(const std::optional<double>& value) { return value ? json(*value) : json(nullptr); }

json ToJson(const FitParameter& p) {
  return {{"value", Number(p.value)}, {"std_error", Number(p.std_error)}};
}

json ToJson(const Prediction& p) {
  return {{"x", Number(p.x)}, {"y", Number(p.y)}, {"std_error", Number(p.std_error)}};
}

std::string CsvRow(const std::string& quantity, const std::string& label, double x, double value,
                   double std_error) {
  return quantity + "," + CsvCell(label) + "," + CsvNumber(x) + "," + CsvNumber(value) + "," +
         CsvNumber(std_error) + "\n";
}

std::vector<ScalingPoint> ReadPoints(const CsvTable& table) {
  const size_t x = table.Column("x"), y = table.Column("y");
  const std::optional<size_t> label = table.FindColumn("label");
  Check(table.rows() > 0, "no points after the header", {.file = table.path()});
  std::vector<ScalingPoint> points;
  for (size_t r = 0; r < table.rows(); ++r) {
    points.push_back({table.Number(r, x), table.Number(r, y), label ? table.Cell(r, *label) : ""});
  }
  return points;
}

}  // namespace

ScalingReport FitScalingLawFromCsv(const std::string& path, const ScalingFitOptions& options,
                                   const std::vector<double>& extrapolate) {
  options.Check();
  ScalingReport report{.options = options};
  const CsvTable table = CsvTable::Read(path);
  report.points = ReadPoints(table);
  try {
    report.fit = FitScalingLaw(report.points, options);
  } catch (const Error& e) {
    throw table.AtLine(e);
  }
  for (const ScalingPoint& p : report.points) report.fitted.push_back(Predict(report.fit, p.x));
  for (double x : extrapolate) report.extrapolation.push_back(Predict(report.fit, x));
  return report;
}

json ScalingReportToJson(const ScalingReport& r) {
  const ScalingFit& f = r.fit;
  const bool power = f.form == ScalingForm::kPower;
  json out = {
      {"form", ToString(f.form)},
      {"robust", ToString(f.robust)},
      {"robust_scale", Number(f.robust_scale)},
      {"bounds",
       {{"b_min", power ? Optional(r.options.b_min) : json(nullptr)},
        {"c_min", power ? Optional(r.options.c_min) : json(nullptr)}}},
      {"points", f.points},
      {"dof", f.dof},
      {"parameters", {{"a", ToJson(f.a)}, {"b", ToJson(f.b)}, {"c", power ? ToJson(f.c) : json()}}},
      {"rss", Number(f.rss)},
      {"sigma2", Number(f.sigma2)},
      {"r2", Number(f.r2)},
      {"fit_space", power ? "y" : "log y"},
      {"converged", f.converged},
      {"iterations", f.iterations},
      {"termination", f.termination},
      {"at_bound", f.at_bound},
      {"fitted", json::array()},
      {"extrapolation", json::array()}};
  for (size_t i = 0; i < r.points.size(); ++i) {
    json row = ToJson(r.fitted[i]);
    row["label"] = r.points[i].label;
    row["observed"] = r.points[i].y;
    out["fitted"].push_back(row);
  }
  for (const Prediction& p : r.extrapolation) out["extrapolation"].push_back(ToJson(p));
  return out;
}

std::string ScalingReportToCsv(const ScalingReport& r) {
  const ScalingFit& f = r.fit;
  std::string out = "quantity,label,x,value,std_error\n";
  out += CsvRow("a", "", NAN, f.a.value, f.a.std_error);
  out += CsvRow("b", "", NAN, f.b.value, f.b.std_error);
  if (f.form == ScalingForm::kPower) out += CsvRow("c", "", NAN, f.c.value, f.c.std_error);
  out += CsvRow("rss", "", NAN, f.rss, NAN);
  out += CsvRow("sigma2", "", NAN, f.sigma2, NAN);
  out += CsvRow("r2", "", NAN, f.r2, NAN);
  for (size_t i = 0; i < r.points.size(); ++i) {
    const Prediction& p = r.fitted[i];
    out += CsvRow("fitted", r.points[i].label, p.x, p.y, p.std_error);
  }
  for (const Prediction& p : r.extrapolation)
    out += CsvRow("extrapolation", "", p.x, p.y, p.std_error);
  return out;
}

}  // namespace wm::metrics

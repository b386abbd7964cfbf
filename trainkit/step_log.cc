#include "trainkit/step_log.h"

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/tfrecord_frame.h"

namespace wm::trainkit {
namespace {

std::vector<std::string> SplitCells(const std::string& line) {
  std::vector<std::string> cells;
  std::istringstream in(line);
  std::string cell;
  while (std::getline(in, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();  // a trailing empty cell
  return cells;
}

void AppendToFile(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::app | std::ios::binary);
  out << bytes;
  out.flush();
  Check(out.good(), "cannot append (disk full?)", {.file = path});
}

}  // namespace

std::string EventFileFor(const std::string& csv_path) {
  const std::filesystem::path p(csv_path);
  return (p.parent_path() / ("events.out.tfevents." + p.stem().string())).string();
}

void TruncateStepLog(const std::string& path, const std::string& header, int64_t step) {
  std::string out = header + "\n";
  if (std::filesystem::exists(path)) {
    std::istringstream in(ReadFile(path));
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      if (!line.empty() && std::stoll(line.substr(0, line.find(','))) <= step) out += line + "\n";
    }
  }
  WriteFileAtomically(path, out);
}

StepLog::StepLog(std::string path, const std::string& header, int64_t resume_step)
    : path_(std::move(path)), events_path_(EventFileFor(path_)) {
  TruncateStepLog(path_, header, resume_step);
  const std::string stem = std::filesystem::path(path_).stem().string();
  const std::vector<std::string> columns = SplitCells(header);
  for (size_t i = 1; i < columns.size(); ++i) tags_.push_back(stem + "/" + columns[i]);
  std::string events = FrameTfRecord(EncodeFileVersionEvent(EventWallTime()));
  std::istringstream kept(ReadFile(path_));
  std::string line;
  std::getline(kept, line);  // the header
  while (std::getline(kept, line)) events += EventFor(line);
  WriteFileAtomically(events_path_, events);
}

void StepLog::Append(const std::string& row) {
  AppendToFile(path_, row + "\n");
  AppendToFile(events_path_, EventFor(row));
}

// One framed event of the row's non-empty cells; cells that are not numbers are left out too,
// since the event file only mirrors the CSV and must never stop a run.
std::string StepLog::EventFor(const std::string& row) const {
  const std::vector<std::string> cells = SplitCells(row);
  std::vector<ScalarSummary> values;
  for (size_t i = 1; i < cells.size() && i <= tags_.size(); ++i) {
    char* end = nullptr;
    const double v = std::strtod(cells[i].c_str(), &end);
    if (!cells[i].empty() && *end == '\0') values.push_back({tags_[i - 1], static_cast<float>(v)});
  }
  const int64_t step = cells.empty() ? 0 : std::strtoll(cells[0].c_str(), nullptr, 10);
  return FrameTfRecord(EncodeScalarsEvent(EventWallTime(), step, values));
}

ImageLog::ImageLog(const std::string& dir, const std::string& name, int64_t resume_step)
    : path_((std::filesystem::path(dir) / ("events.out.tfevents." + name)).string()) {
  std::string events = FrameTfRecord(EncodeFileVersionEvent(EventWallTime()));
  if (std::filesystem::exists(path_)) {
    const std::string old = ReadFile(path_);
    const std::vector<std::string_view> records = UnframeTfRecords(old);
    for (size_t i = 1; i < records.size(); ++i) {  // record 0: the old file_version event
      if (DecodeEventStep(records[i]) <= resume_step) events += FrameTfRecord(records[i]);
    }
  }
  WriteFileAtomically(path_, events);
}

void ImageLog::Append(int64_t step, const ImageSummary& image) {
  AppendToFile(path_, FrameTfRecord(EncodeImageEvent(EventWallTime(), step, image)));
}

double ThroughputWindow::TakeRate() {
  const auto now = std::chrono::steady_clock::now();
  const double secs = std::chrono::duration<double>(now - start_).count();
  const double rate = secs > 0 ? units_ / secs : 0.0;
  start_ = now;
  units_ = 0;
  return rate;
}

}  // namespace wm::trainkit

#include "trainkit/step_log.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/atomic_file.h"
#include "core/error.h"

namespace wm::trainkit {

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
    : path_(std::move(path)) {
  TruncateStepLog(path_, header, resume_step);
}

void StepLog::Append(const std::string& row) {
  std::ofstream out(path_, std::ios::app);
  out << row << '\n';
  out.flush();
  Check(out.good(), "cannot append a row (disk full?)", {.file = path_});
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

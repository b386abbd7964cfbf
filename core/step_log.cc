#include "core/step_log.h"

#include <filesystem>
#include <sstream>

#include "core/atomic_file.h"

namespace wm {

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

}  // namespace wm

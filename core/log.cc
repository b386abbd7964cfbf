#include "core/log.h"

#include <spdlog/sinks/stdout_color_sinks.h>
#include <spdlog/spdlog.h>

namespace wm {

void InitLogging(const std::string& level) {
  auto logger = spdlog::stderr_color_mt("wm");
  logger->set_pattern("%^[%Y-%m-%d %H:%M:%S] [%l]%$ %v");
  logger->set_level(spdlog::level::from_str(level));
  spdlog::set_default_logger(logger);
}

void LogInfo(const std::string& message) { spdlog::info("{}", message); }

void LogWarn(const std::string& message) { spdlog::warn("{}", message); }

}  // namespace wm

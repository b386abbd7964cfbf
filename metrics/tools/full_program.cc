#include "metrics/tools/full_program.h"

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iostream>
#include <string>

#include "core/error.h"
#include "core/paths.h"

namespace wm::metrics {

void HandOverToFullProgram(char** argv) {
  const std::string path = (std::filesystem::path(ExecutableDir()) / kFullProgram).string();
  std::cout.flush();
  execv(path.c_str(), argv);
  throw Error(std::string("cannot start ") + kFullProgram +
                  ", which runs lpips, lpips_style, fvd_style, `seg`, videos and image formats "
                  "other than PNG and JPEG (build it beside wm-metrics: cmake --build build "
                  "--target wm-metrics): " +
                  std::strerror(errno),
              {.file = path});
}

}  // namespace wm::metrics

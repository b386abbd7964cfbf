#pragma once
// Where the shipped configs live: $WMKIT_CONFIGS, else <repo>/configs found relative to the
// running executable (build/bin/ -> ../../configs), else ./configs.
#include <string>

namespace wm {

std::string DefaultConfigsDir();

}  // namespace wm

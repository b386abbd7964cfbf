#include "core/provenance.h"

#include <openssl/opensslv.h>
#include <spdlog/version.h>
#include <zstd.h>

#include "core/sha256.h"

namespace wm {

std::string ConfigHash(const nlohmann::json& config) { return Sha256Hex(config.dump()); }

nlohmann::json CoreLibraryVersions() {
  auto v = [](int a, int b, int c) {
    return std::to_string(a) + "." + std::to_string(b) + "." + std::to_string(c);
  };
  return {{"zstd", ZSTD_versionString()},
          {"openssl", OPENSSL_VERSION_STR},
          {"nlohmann_json", v(NLOHMANN_JSON_VERSION_MAJOR, NLOHMANN_JSON_VERSION_MINOR,
                              NLOHMANN_JSON_VERSION_PATCH)},
          {"spdlog", v(SPDLOG_VER_MAJOR, SPDLOG_VER_MINOR, SPDLOG_VER_PATCH)}};
}

nlohmann::json MakeProvenance(const std::string& tool, const nlohmann::json& config,
                              const nlohmann::json& extra_libraries) {
  nlohmann::json libs = CoreLibraryVersions();
  libs.update(extra_libraries);
  return {{"tool", tool},           {"wmkit_version", kWmkitVersion},
          {"git_commit", kGitCommit}, {"config", config},
          {"config_hash", ConfigHash(config)}, {"libraries", libs}};
}

std::string VersionString(const std::string& tool) {
  return tool + " (wmkit " + kWmkitVersion + ", commit " + kGitCommit + ")";
}

}  // namespace wm

#include "core/provenance.h"

#include <openssl/opensslv.h>
#include <spdlog/version.h>
#include <zstd.h>

#include <algorithm>

#include "core/error.h"
#include "core/sha256.h"

namespace wm {

std::string ConfigHash(const nlohmann::json& config) { return Sha256Hex(config.dump()); }

void CheckResumeConfig(const std::string& stored_hash, const nlohmann::json& stored,
                       const nlohmann::json& current) {
  const std::string hash = ConfigHash(current);
  if (stored_hash == hash || ConfigHash(stored) == hash) return;
  constexpr size_t kShown = 5;
  const nlohmann::json patch = nlohmann::json::diff(stored, current);
  std::string changes;
  for (size_t i = 0; i < patch.size() && i < kShown; ++i) {
    const nlohmann::json::json_pointer path(patch[i].at("path").get<std::string>());
    std::string key = path.empty() ? "config" : path.to_string().substr(1);
    std::replace(key.begin(), key.end(), '/', '.');
    const std::string before = stored.contains(path) ? stored.at(path).dump() : "(none)";
    const std::string after = current.contains(path) ? current.at(path).dump() : "(none)";
    changes += (i ? ", " : "") + key + ": " + before + " -> " + after;
  }
  if (patch.size() > kShown) changes += " and " + std::to_string(patch.size() - kShown) + " more";
  throw Error("checkpoint was trained with a different config (" + changes +
              "); --resume needs the same config: train with another config into a new --out");
}

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
  return {{"tool", tool},     {"wmkit_version", kWmkitVersion},    {"git_commit", kGitCommit},
          {"config", config}, {"config_hash", ConfigHash(config)}, {"libraries", libs}};
}

std::string VersionString(const std::string& tool) {
  return tool + " (wmkit " + kWmkitVersion + ", commit " + kGitCommit + ")";
}

}  // namespace wm

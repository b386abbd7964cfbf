#pragma once
// What every output records about how it was made: tool, wmkit version, git commit, the
// config that shaped it and its hash, and the versions of the libraries that touched the bytes.
#include <nlohmann/json.hpp>
#include <string>

namespace wm {

extern const char* const kGitCommit;  // generated at build time (cmake/WriteGitCommit.cmake)
inline constexpr const char* kWmkitVersion = "0.1.0";

// SHA-256 of the config as compact JSON with sorted keys (nlohmann sorts object keys).
std::string ConfigHash(const nlohmann::json& config);

// For --resume: throws wm::Error unless a checkpoint's config equals the current one, naming
// up to five keys that differ ("checkpoint was trained with a different config (train.steps:
// 300 -> 600); ..."). `stored_hash` is the hash the checkpoint recorded and `stored` its config
// re-read with today's defaults, so a key added to wmkit after the run (at its default) is no
// difference.
void CheckResumeConfig(const std::string& stored_hash, const nlohmann::json& stored,
                       const nlohmann::json& current);

// Versions of the libraries core links (zstd, OpenSSL, nlohmann_json, spdlog).
nlohmann::json CoreLibraryVersions();

// {"tool", "wmkit_version", "git_commit", "config", "config_hash", "libraries"}.
nlohmann::json MakeProvenance(const std::string& tool, const nlohmann::json& config,
                              const nlohmann::json& extra_libraries = nlohmann::json::object());

// "wmkit 0.1.0 (commit abc...)" for --version.
std::string VersionString(const std::string& tool);

}  // namespace wm

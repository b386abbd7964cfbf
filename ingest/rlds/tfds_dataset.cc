#include "ingest/rlds/tfds_dataset.h"

#include <algorithm>
#include <filesystem>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/json_int.h"

namespace wm::rlds {
namespace fs = std::filesystem;
using nlohmann::json;

int64_t FeatureSpec::ElementSize() const {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

namespace {

json ReadJson(const fs::path& path) {
  Check(fs::exists(path), "missing TFDS metadata file", {.file = path.string()});
  json j = json::parse(ReadFile(path.string()), nullptr, false);
  Check(!j.is_discarded(), "not valid JSON", {.file = path.string()});
  return j;
}

std::string ClassName(const json& node) {
  std::string cls = node.value("pythonClassName", "");
  auto dot = cls.rfind('.');
  return dot == std::string::npos ? cls : cls.substr(dot + 1);
}

// Walks TFDS's FeaturesDict / Dataset nesting, flattening names with '/' like the TFRecords do.
void Flatten(const json& node, const std::string& prefix, bool per_step,
             std::map<std::string, FeatureSpec>& out) {
  if (node.contains("featuresDict")) {
    for (const auto& [k, v] : node["featuresDict"].at("features").items()) {
      Flatten(v, prefix.empty() ? k : prefix + "/" + k, per_step, out);
    }
    return;
  }
  if (node.contains("sequence")) {
    Flatten(node["sequence"].at("feature"), prefix, true, out);
    return;
  }
  FeatureSpec spec;
  spec.tfds_class = ClassName(node);
  spec.per_step = per_step;
  if (node.contains("description") && node["description"].is_string())
    spec.description = node["description"].get<std::string>();
  const json* t = node.contains("tensor")  ? &node["tensor"]
                  : node.contains("image") ? &node["image"]
                                           : nullptr;
  if (t != nullptr) {
    spec.dtype = t->value("dtype", "");
    if (t->contains("shape") && (*t)["shape"].contains("dimensions")) {
      for (const auto& d : (*t)["shape"]["dimensions"]) {
        spec.shape.push_back(d.is_string() ? std::stoll(d.get<std::string>())
                                           : JsonInt<int64_t>(d));
      }
    }
    spec.encoding = t->value("encodingFormat", "");
  } else if (node.contains("text")) {
    spec.dtype = "string";
  }
  out[prefix] = spec;
}

fs::path ResolveVersionDir(const fs::path& path) {
  if (fs::exists(path / "dataset_info.json")) return path;
  Check(fs::is_directory(path), "RLDS input is not a directory", {.file = path.string()});
  std::vector<fs::path> versions;
  for (const auto& e : fs::directory_iterator(path)) {
    if (e.is_directory() && fs::exists(e.path() / "dataset_info.json"))
      versions.push_back(e.path());
  }
  Check(!versions.empty(),
        "no dataset_info.json here or in a version subdirectory (expected <name>/<version>/)",
        {.file = path.string()});
  std::sort(versions.begin(), versions.end());
  return versions.back();
}

}  // namespace

TfdsDataset OpenTfdsDataset(const std::string& path) {
  TfdsDataset d;
  fs::path dir = ResolveVersionDir(path);
  d.dir = dir.string();
  json info = ReadJson(dir / "dataset_info.json");
  d.name = info.value("name", dir.parent_path().filename().string());
  d.version = info.value("version", dir.filename().string());
  json features = ReadJson(dir / "features.json");
  try {
    Flatten(features, "", false, d.features);
  } catch (const std::exception& e) {
    throw Error(std::string("malformed TFDS feature spec: ") + e.what(),
                {.file = (dir / "features.json").string()});
  }
  return d;
}

std::vector<std::string> TfdsDataset::SplitFiles(const std::string& split) const {
  // TFDS names shards `<name>-<split>.tfrecord-NNNNN-of-MMMMM`.
  std::string prefix = name + "-" + split + ".tfrecord-";
  std::vector<std::string> files;
  for (const auto& e : fs::directory_iterator(dir)) {
    std::string f = e.path().filename().string();
    if (e.is_regular_file() && f.rfind(prefix, 0) == 0) files.push_back(e.path().string());
  }
  std::sort(files.begin(), files.end());
  Check(!files.empty(),
        "no TFRecord files for split '" + split + "' (expected " + prefix + "NNNNN-of-MMMMM)",
        {.file = dir});
  return files;
}

}  // namespace wm::rlds

#include "ingest/tabletop/tfds_features.h"

#include <cstdio>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "ingest/tabletop/episode.h"

namespace wm::tabletop {
namespace {

// TFDS serializes the FeatureConnector protos in field order, so the order of insertion
// matters here: ordered_json keeps it.
using OrderedJson = nlohmann::ordered_json;
constexpr const char* kTfds = "tensorflow_datasets.core.features.";

OrderedJson Shape(const std::vector<int>& dims) {
  if (dims.empty()) return OrderedJson::object();
  OrderedJson d = OrderedJson::array();
  for (int x : dims) d.push_back(std::to_string(x));  // int64 fields are JSON strings
  return {{"dimensions", d}};
}

OrderedJson TensorFeature(const std::string& dtype, const std::vector<int>& dims) {
  return {{"pythonClassName", std::string(kTfds) + "tensor_feature.Tensor"},
          {"tensor", {{"shape", Shape(dims)}, {"dtype", dtype}, {"encoding", "none"}}}};
}

OrderedJson ScalarFeature(const std::string& dtype) {
  return {{"pythonClassName", std::string(kTfds) + "scalar.Scalar"},
          {"tensor", {{"shape", Shape({})}, {"dtype", dtype}, {"encoding", "none"}}}};
}

OrderedJson ImageFeature(int size, int channels, const std::string& dtype,
                         const std::string& format) {
  return {
      {"pythonClassName", std::string(kTfds) + "image_feature.Image"},
      {"image",
       {{"shape", Shape({size, size, channels})}, {"dtype", dtype}, {"encodingFormat", format}}}};
}

OrderedJson TextFeature() {
  return {{"pythonClassName", std::string(kTfds) + "text_feature.Text"},
          {"text", OrderedJson::object()}};
}

std::map<std::string, OrderedJson> FeatureSpecs(int size) {
  return {{kImageKey, ImageFeature(size, 3, "uint8", "jpeg")},
          {kDepthKey, ImageFeature(size, 1, "uint16", "png")},
          {kSegmentationKey, ImageFeature(size, 1, "uint8", "png")},
          {kActionKey, TensorFeature("float32", {7})},
          {kRewardKey, ScalarFeature("float32")},
          {kDiscountKey, ScalarFeature("float32")},
          {kIsFirstKey, ScalarFeature("bool")},
          {kIsLastKey, ScalarFeature("bool")},
          {kIsTerminalKey, ScalarFeature("bool")},
          {kInstructionKey, TextFeature()},
          {kPolicyIdKey, TextFeature()},
          {kEpisodeSeedKey, ScalarFeature("int64")},
          {kIntrinsicsKey, TensorFeature("float32", {4})}};
}

OrderedJson FeaturesDict(const std::map<std::string, OrderedJson>& children) {
  OrderedJson features = OrderedJson::object();
  for (const auto& [name, feature] : children) features[name] = feature;  // sorted, like TFDS
  return {{"pythonClassName", std::string(kTfds) + "features_dict.FeaturesDict"},
          {"featuresDict", {{"features", features}}}};
}

// Rebuilds the nesting from flattened keys: each path component is a FeaturesDict, except the
// top-level `steps`, which is the RLDS Dataset (a sequence of unknown length).
OrderedJson Nest(const std::map<std::string, OrderedJson>& flat, const std::string& prefix) {
  std::map<std::string, OrderedJson> children;
  std::set<std::string> groups;
  for (const auto& [key, feature] : flat) {
    if (key.compare(0, prefix.size(), prefix) != 0) continue;
    const std::string rest = key.substr(prefix.size());
    const size_t slash = rest.find('/');
    if (slash == std::string::npos) {
      children[rest] = feature;
    } else {
      groups.insert(rest.substr(0, slash));
    }
  }
  for (const std::string& group : groups) {
    OrderedJson dict = Nest(flat, prefix + group + "/");
    if (prefix.empty() && group == "steps") {
      dict = {{"pythonClassName", std::string(kTfds) + "dataset_feature.Dataset"},
              {"sequence", {{"length", "-1"}, {"feature", dict}}}};
    }
    children[group] = dict;
  }
  return FeaturesDict(children);
}

}  // namespace

std::vector<std::string> TabletopFeatureKeys() {
  std::vector<std::string> keys;
  for (const auto& [key, feature] : FeatureSpecs(64)) keys.push_back(key);
  return keys;
}

std::string TabletopFeaturesJson(int size) { return Nest(FeatureSpecs(size), "").dump(2); }

std::string DatasetInfoJson(const std::string& name, const std::string& version,
                            const std::string& description, const std::vector<SplitInfo>& splits) {
  nlohmann::json info;  // std::map-backed: keys come out sorted, as TFDS writes them
  info["citation"] = "";
  info["description"] = description;
  info["fileFormat"] = "tfrecord";
  info["moduleName"] = name;
  info["name"] = name;
  info["releaseNotes"] = {{version, "Initial release."}};
  info["splits"] = nlohmann::json::array();
  for (const SplitInfo& split : splits) {
    nlohmann::json lengths = nlohmann::json::array();
    for (uint64_t n : split.shard_lengths) lengths.push_back(std::to_string(n));
    info["splits"].push_back({{"filepathTemplate", "{DATASET}-{SPLIT}.{FILEFORMAT}-{SHARD_X_OF_Y}"},
                              {"name", split.name},
                              {"numBytes", std::to_string(split.num_bytes)},
                              {"shardLengths", lengths}});
  }
  info["version"] = version;
  return info.dump(2);
}

std::string TfdsShardFileName(const std::string& name, const std::string& split, int shard,
                              int num_shards) {
  char suffix[32];
  std::snprintf(suffix, sizeof(suffix), "%05d-of-%05d", shard, num_shards);
  return name + "-" + split + ".tfrecord-" + suffix;
}

}  // namespace wm::tabletop

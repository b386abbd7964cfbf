#pragma once
// A TFDS-prepared dataset directory (`<name>/<version>/` with dataset_info.json, features.json
// and TFRecord shards), read without TensorFlow: which files hold a split, and the flattened
// feature spec (`steps/observation/image` -> Image uint8 [H, W, 3] jpeg, ...).
#include <cstdint>
#include <map>
#include <string>
#include <vector>

namespace wm::rlds {

struct FeatureSpec {
  std::string tfds_class;       // "Tensor", "Image", "Text", "Scalar"
  std::string dtype;            // "float32", "int64", "bool", "uint8", "string"...
  std::vector<int64_t> shape;   // per element (per step for step features); [] for scalars
  std::string encoding;         // images: "jpeg" / "png"
  bool per_step = false;        // under the `steps` sequence
  std::string description;      // the builder's words for it ("" when none), for people
  int64_t ElementSize() const;  // product of shape (1 for scalars)
};

struct TfdsDataset {
  std::string dir;   // the version directory
  std::string name;  // dataset_info.json "name"
  std::string version;
  std::map<std::string, FeatureSpec> features;                          // flattened key -> spec
  std::vector<std::string> SplitFiles(const std::string& split) const;  // sorted paths
};

// `path` is the version directory, or a dataset directory holding version directories (the
// highest version is taken). Throws wm::Error naming the file and key on malformed metadata.
TfdsDataset OpenTfdsDataset(const std::string& path);

}  // namespace wm::rlds

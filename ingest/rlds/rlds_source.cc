#include "ingest/rlds/rlds_source.h"

#include <cmath>
#include <filesystem>

#include "core/error.h"
#include "ingest/rlds/example.h"
#include "ingest/rlds/tfrecord.h"

namespace wm::ingest {
namespace fs = std::filesystem;
using rlds::Example;
using rlds::FeatureSpec;

namespace {

// Values of a numeric feature as float, whatever list type TFDS used (bools and ints are int64).
std::vector<float> NumericValues(const Example& ex, const std::string& key) {
  std::string kind = ex.KindOf(key);
  if (kind == "float") return ex.Floats(key);
  if (kind == "int64") {
    std::vector<int64_t> v = ex.Int64s(key);
    return {v.begin(), v.end()};
  }
  if (kind == "missing") throw Error("feature key missing from the episode", {.key = key});
  throw Error("expected a numeric (float or int64) feature, found " + kind, {.key = key});
}

// A per-step numeric feature of `width` values per step, checked against T.
std::vector<float> StepValues(const Example& ex, const std::string& key, int64_t t, int64_t width) {
  std::vector<float> v = NumericValues(ex, key);
  Check(static_cast<int64_t>(v.size()) == t * width,
        "holds " + std::to_string(v.size()) + " values, expected " + std::to_string(t) +
            " steps x " + std::to_string(width),
        {.key = key});
  return v;
}

std::vector<uint8_t> Flags(const Example& ex, const std::string& key, int64_t t) {
  std::vector<uint8_t> out;
  for (float v : StepValues(ex, key, t, 1)) out.push_back(v != 0.0f ? 1 : 0);
  return out;
}

// What features.json promises about every frame, checked when the frames are decoded.
void DeclareShape(const FeatureSpec& spec, EncodedFrames& frames) {
  const auto& s = spec.shape;
  if (s.size() != 3 || s[0] <= 0 || s[1] <= 0 || s[2] <= 0) return;  // unknown or variable
  frames.height = static_cast<int>(s[0]);
  frames.width = static_cast<int>(s[1]);
  frames.channels = static_cast<int>(s[2]);
  frames.dtype = spec.dtype.empty() ? "uint8" : spec.dtype;
}

std::string FirstText(const Example& ex, const std::string& key) {
  std::vector<std::string> v = ex.Bytes(key);
  return v.empty() ? "" : v.front();
}

}  // namespace

RldsSource::RldsSource(const std::string& path, const std::string& split,
                       const std::string& mapping_file, const std::string& configs_dir)
    : dataset_(rlds::OpenTfdsDataset(path)), split_(split) {
  mapping_ = rlds::LoadDatasetMapping(
      mapping_file.empty() ? rlds::FindMappingFile(configs_dir, dataset_.name) : mapping_file);
  // Check the mapping against the feature spec now, before any episode is read.
  auto require = [&](const std::string& key, const char* what) {
    Check(dataset_.features.count(key) == 1,
          std::string("mapping names ") + what + " feature '" + key +
              "', which features.json does not declare",
          {.file = mapping_.file});
  };
  require(mapping_.image, "image");
  if (mapping_.depth) require(*mapping_.depth, "depth");
  if (mapping_.segmentation) require(*mapping_.segmentation, "segmentation");
  int width = 0;
  for (const auto& part : mapping_.action) {
    if (part.key.empty()) {
      width += part.zeros;
      continue;
    }
    require(part.key, "action");
    const auto size = static_cast<int>(dataset_.features[part.key].ElementSize());
    for (int index : part.select) {
      Check(index >= 0 && index < size,
            "select index " + std::to_string(index) + " is outside the feature's " +
                std::to_string(size) + " values per step",
            {.file = mapping_.file, .key = part.key});
    }
    width += part.Width(size);
  }
  if (mapping_.action_space == "eef_delta") {
    Check(width == kActionDim,
          "action parts add up to " + std::to_string(width) +
              " dimensions, expected 7 (Δxyz, Δrpy, gripper); for another action set "
              "action_space: joint_position or other",
          {.file = mapping_.file, .key = "action"});
  }
  Check(width >= 1 && width <= kMaxActionDim,
        "action parts add up to " + std::to_string(width) + " dimensions, expected 1 to " +
            std::to_string(kMaxActionDim),
        {.file = mapping_.file, .key = "action"});
  action_width_ = width;
}

std::vector<EpisodeRef> RldsSource::ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) {
  std::vector<EpisodeRef> refs;
  for (const auto& file : dataset_.SplitFiles(split_)) {
    std::string rel = fs::relative(file, dataset_.dir).string();
    std::vector<uint64_t> offsets;
    try {
      offsets = rlds::TfRecordReader(file).record_offsets();
    } catch (const Error& e) {
      if (damaged == nullptr) throw;
      // Keep the intact records before the damage; the damage itself is reported.
      offsets = rlds::ScanTfRecordOffsets(file, /*stop_at_damage=*/true);
      damaged->push_back({rel, static_cast<int64_t>(offsets.size()), e.message()});
    }
    for (size_t k = 0; k < offsets.size(); ++k) {
      refs.push_back({file, rel, static_cast<int64_t>(k), offsets[k]});
    }
  }
  return refs;
}

Episode RldsSource::Load(const EpisodeRef& ref) const {
  try {
    Episode e = MapExample(rlds::ReadTfRecordAt(ref.path, ref.offset));
    e.source_file = ref.rel_path;
    e.source_record = ref.record;
    e.episode_key = ref.rel_path + "#" + std::to_string(ref.record);
    return e;
  } catch (const Error& e) {
    throw e.WithRecord(ref.record).WithFile(ref.path);
  }
}

Episode RldsSource::MapExample(const std::string& bytes) const {
  Example ex(bytes);
  Episode e;
  EncodedFrames image;
  image.frames = ex.Bytes(mapping_.image);
  const int64_t t = static_cast<int64_t>(image.frames.size());
  Check(t > 0, "episode has no steps (empty image list)", {.key = mapping_.image});
  e.num_steps = t;
  e.images["image"] = std::move(image);
  DeclareShape(dataset_.features.at(mapping_.image), e.images["image"]);
  auto optional_frames = [&](const std::optional<std::string>& key, const char* name) {
    if (!key) return;
    EncodedFrames f;
    f.frames = ex.Bytes(*key);
    DeclareShape(dataset_.features.at(*key), f);
    Check(static_cast<int64_t>(f.frames.size()) == t,
          "holds " + std::to_string(f.frames.size()) + " frames, expected " + std::to_string(t),
          {.key = *key});
    e.images[name] = std::move(f);
  };
  optional_frames(mapping_.depth, "depth");
  optional_frames(mapping_.segmentation, "segmentation");

  e.action_dim = action_width_;
  e.action_space = mapping_.action_space;
  e.actions.assign(static_cast<size_t>(t) * action_width_, 0.0f);
  int dim = 0;
  for (const auto& part : mapping_.action) {
    if (part.key.empty()) {
      dim += part.zeros;  // already zero
      continue;
    }
    const int64_t size = dataset_.features.at(part.key).ElementSize();
    std::vector<float> v = StepValues(ex, part.key, t, size);
    std::vector<int> select = part.select;
    if (select.empty())
      for (int i = 0; i < size; ++i) select.push_back(i);
    for (int64_t s = 0; s < t; ++s) {
      for (size_t j = 0; j < select.size(); ++j) {
        double x = v[static_cast<size_t>(s * size + select[j])] * part.scale + part.offset;
        e.actions[static_cast<size_t>(s * action_width_ + dim) + j] = static_cast<float>(x);
      }
    }
    dim += static_cast<int>(select.size());
  }
  e.rewards =
      mapping_.reward ? StepValues(ex, *mapping_.reward, t, 1) : std::vector<float>(t, 0.0f);
  e.discounts =
      mapping_.discount ? StepValues(ex, *mapping_.discount, t, 1) : std::vector<float>(t, 1.0f);
  e.is_first = Flags(ex, mapping_.is_first, t);
  e.is_last = Flags(ex, mapping_.is_last, t);
  e.is_terminal = Flags(ex, mapping_.is_terminal, t);
  if (mapping_.language_instruction) {
    e.language_instruction = FirstText(ex, *mapping_.language_instruction);
  }
  if (mapping_.policy_id) e.policy_id = FirstText(ex, *mapping_.policy_id);
  if (mapping_.episode_seed) {
    std::vector<int64_t> seed = ex.Int64s(*mapping_.episode_seed);
    if (!seed.empty()) e.episode_seed = seed.front();
  }
  return e;
}

nlohmann::json RldsSource::Describe() const {
  return {{"format", "rlds"},
          {"dataset", dataset_.name},
          {"version", dataset_.version},
          {"split", split_},
          {"mapping", mapping_.ToJson()}};
}

}  // namespace wm::ingest

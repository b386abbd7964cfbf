#include "tests/core/test_util.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "core/error.h"
#include "core/shard/dataset_writer.h"
#include "core/tensor_archive.h"

namespace wm::test {
namespace fs = std::filesystem;

TempDir::TempDir() {
  static int counter = 0;
  path_ = fs::temp_directory_path() /
          ("wmkit-test-" + std::to_string(::getpid()) + "-" + std::to_string(counter++));
  fs::remove_all(path_);
  fs::create_directories(path_);
}

TempDir::~TempDir() {
  std::error_code ec;
  fs::remove_all(path_, ec);
}

Episode MakeEpisode(int steps, uint64_t seed, const std::string& key) {
  std::mt19937_64 rng(seed);
  auto uniform = [&] {
    return static_cast<float>(static_cast<double>(rng() >> 11) * 0x1.0p-53) - 0.5f;
  };
  Episode e;
  e.episode_key = key;
  e.source_file = key + ".tfrecord";
  e.source_record = static_cast<int64_t>(seed);
  e.language_instruction = "push the block";
  e.policy_id = "expert";
  e.episode_seed = static_cast<int64_t>(seed);
  e.num_steps = steps;
  for (int i = 0; i < steps * kActionDim; ++i) e.actions.push_back(uniform());
  for (int t = 0; t < steps; ++t) {
    e.rewards.push_back(t == steps - 1 ? 1.0f : 0.0f);
    e.discounts.push_back(1.0f);
    e.is_first.push_back(t == 0);
    e.is_last.push_back(t == steps - 1);
    e.is_terminal.push_back(t == steps - 1);
  }
  EncodedFrames& f = e.images["image"];
  f.encoding = "jpeg";
  f.height = 4, f.width = 4, f.channels = 3;
  for (int t = 0; t < steps; ++t) {
    f.frames.push_back(std::string("\xFF\xD8\xFF", 3) +
                       std::string(10 + t, static_cast<char>('a' + t % 26)));
  }
  return e;
}

void SetPngFrames(Episode& episode, std::vector<std::string> frames, int size) {
  EncodedFrames& f = episode.images["image"];
  f.encoding = "png";
  f.height = f.width = size;
  f.channels = 3;
  f.frames = std::move(frames);
}

void FinishTrainSplit(shard::DatasetWriter& writer, const std::string& name) {
  shard::DatasetIndex meta;
  meta.dataset = name;
  meta.split = "train";
  writer.Finish(meta);
}

std::vector<std::vector<uint32_t>> MakeTokenDataset(const std::string& dir, int episodes,
                                                    int num_parts, int grid_h, int grid_w,
                                                    int64_t num_codes, uint64_t seed,
                                                    int64_t action_dim, int levels) {
  tokens::TokenIndex base;
  base.dataset = "unit";
  base.split = "train";
  base.tokenizer = {.checkpoint_sha256 = "ckpt",
                    .config_hash = "cfg",
                    .num_codes = num_codes,
                    .grid_h = grid_h,
                    .grid_w = grid_w,
                    .levels = levels,
                    .image_size = 8 * grid_h};
  base.token_dtype = num_codes > 65536 ? "uint32" : "uint16";
  if (action_dim != kActionDim) {
    base.action_dim = action_dim;
    base.action_space = "joint_position";
    base.action_stats = shard::ComputeActionStats({}, action_dim);
  }
  std::mt19937_64 rng(seed);
  std::vector<std::vector<uint32_t>> all;
  for (int part = 0; part < num_parts; ++part) {
    tokens::TokenPartWriter writer(dir, part, num_parts, base);
    auto [first, last] = tokens::PartEpisodeRange(episodes, part, num_parts);
    for (int64_t k = first; k < last; ++k) {
      Episode e = MakeEpisode(3 + static_cast<int>(k % 4), seed + k, "ep" + std::to_string(k));
      e.policy_id = "policy" + std::to_string(k % 2);
      if (action_dim != kActionDim) {
        e.action_dim = action_dim;
        e.action_space = base.action_space;
        e.actions.resize(static_cast<size_t>(e.num_steps * action_dim));
        for (size_t i = 0; i < e.actions.size(); ++i) e.actions[i] = k + i / 100.0f;
      }
      std::vector<uint32_t> t(static_cast<size_t>(e.num_steps * levels * grid_h * grid_w));
      for (auto& v : t) v = static_cast<uint32_t>(rng() % static_cast<uint64_t>(num_codes));
      writer.AddEpisode({.num_frames = e.num_steps,
                         .source_episode = k,
                         .episode_key = e.episode_key,
                         .policy_id = e.policy_id,
                         .language_instruction = e.language_instruction,
                         .episode_seed = e.episode_seed},
                        t, e);
      all.push_back(std::move(t));
    }
    writer.Finish();
  }
  tokens::AssembleIndexIfComplete(dir, num_parts, base);
  return all;
}

namespace {
std::string EnvOr(const char* name, const char* fallback) {
  const char* value = std::getenv(name);
  return value != nullptr ? value : fallback;
}
}  // namespace

// The defaults are compiled in (tests/core/CMakeLists.txt); ctest sets the variables.
std::string SourceDir() { return EnvOr("WM_SOURCE_DIR", WM_DEFAULT_SOURCE_DIR); }
std::string BinDir() { return EnvOr("WM_BIN_DIR", WM_DEFAULT_BIN_DIR); }
std::string SamplesDir() {
  const char* shared = std::getenv("WM_SHARED_DIR");
  return (shared ? std::string(shared) : SourceDir() + "/../shared") + "/samples";
}

std::string ErrorText(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "(no error)";
}

std::vector<std::string> TensorNames(const std::string& archive, const std::string& prefix) {
  std::vector<std::string> names;
  for (const std::string& name : TensorArchiveReader(archive).Names()) {
    if (name.rfind(prefix, 0) == 0) names.push_back(name);
  }
  return names;
}

std::vector<std::string> ChangedTensors(const std::string& a, const std::string& b,
                                        const std::string& prefix) {
  const TensorArchiveReader ra(a), rb(b);
  std::vector<std::string> changed;
  for (const std::string& name : TensorNames(a, prefix)) {
    const ArchiveTensor& x = ra.Get(name);
    const bool same = rb.Contains(name) && rb.Get(name).length == x.length &&
                      std::memcmp(rb.Get(name).data, x.data, x.length) == 0;
    if (!same) changed.push_back(name);
  }
  return changed;
}

double MaxFloat32Difference(const std::string& a, const std::string& b, const std::string& prefix) {
  const TensorArchiveReader ra(a), rb(b);
  double worst = 0;
  for (const std::string& name : TensorNames(a, prefix)) {
    const ArchiveTensor& x = ra.Get(name);
    if (x.dtype != DType::kFloat32) continue;
    const std::span<const float> p = ra.Float32(name, x.shape), q = rb.Float32(name, x.shape);
    for (size_t i = 0; i < p.size(); ++i) {
      worst = std::max<double>(worst, std::abs(p[i] - q[i]));
    }
  }
  return worst;
}

void FlipByte(const std::string& file, uint64_t offset) {
  std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
  f.seekg(static_cast<std::streamoff>(offset));
  char c = 0;
  f.get(c);
  f.seekp(static_cast<std::streamoff>(offset));
  f.put(static_cast<char>(c ^ 0x40));
}

void Truncate(const std::string& file, uint64_t new_size) { fs::resize_file(file, new_size); }

}  // namespace wm::test

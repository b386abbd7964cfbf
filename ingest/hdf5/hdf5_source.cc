#include "ingest/hdf5/hdf5_source.h"

#include <algorithm>
#include <charconv>
#include <filesystem>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <utility>

#include "core/byte_fields.h"
#include "core/child_process.h"
#include "core/error.h"
#include "ingest/hdf5/hdf5_file.h"
#include "ingest/hdf5/raw_demo.h"
#include "ingest/image_codec.h"

namespace wm::ingest {
namespace {

namespace fs = std::filesystem;
using h5::Dataset;
using h5::Handle;
using nlohmann::json;

constexpr const char* kNoDataGroup =
    "HDF5 file has no 'data' group (expected robomimic/LIBERO layout data/demo_N/...)";

// Opens a file's data/ group, or throws kNoDataGroup naming the file.
Handle OpenDataGroup(hid_t file, const std::string& path) {
  Handle data = h5::Exists(file, "data") ? h5::OpenGroup(file, "data") : Handle();
  Check(data.ok(), kNoDataGroup, {path});
  return data;
}

std::optional<int64_t> DemoNumber(const std::string& name) {
  constexpr std::string_view kPrefix = "demo_";
  if (!name.starts_with(kPrefix)) return {};
  int64_t n = 0;
  const char* end = name.data() + name.size();
  auto [ptr, ec] = std::from_chars(name.data() + kPrefix.size(), end, n);
  if (ec != std::errc() || ptr != end || n < 0) return {};
  return n;
}

std::string ChooseCamera(const std::vector<std::string>& obs_keys) {
  auto has = [&](const std::string& k) {
    return std::find(obs_keys.begin(), obs_keys.end(), k) != obs_keys.end();
  };
  for (const char* preferred : {"agentview_rgb", "agentview_image", "image"}) {
    if (has(preferred)) return preferred;
  }
  for (const auto& key : obs_keys) {  // sorted
    if (key.ends_with("_rgb") || key.ends_with("_image")) return key;
  }
  return "";
}

// Opens data/demo_N of one file and reads its datasets; every error names file, demo and key.
// Only constructed while an h5::Lock is held.
class DemoReader {
 public:
  explicit DemoReader(const EpisodeRef& ref)
      : path_(ref.path),
        demo_(ref.record),
        file_(h5::OpenFile(path_)),
        data_(OpenDataGroup(file_.get(), path_)) {
    std::string name = "demo_" + std::to_string(demo_);
    if (h5::Exists(data_.get(), name)) group_ = h5::OpenGroup(data_.get(), name);
    if (!group_.ok()) throw Fail("", "no group data/" + name);
  }

  Error Fail(const std::string& key, const std::string& message) const {
    return Error(message, {path_, demo_, "demo", key});
  }
  bool Has(const std::string& key) const { return h5::Exists(group_.get(), key); }
  // Members of the group `key`; empty when it is missing or not a group.
  std::vector<std::string> Children(const std::string& key) const {
    Handle group = Has(key) ? h5::OpenGroup(group_.get(), key) : Handle();
    try {
      return group.ok() ? h5::ChildNames(group.get()) : std::vector<std::string>{};
    } catch (const Error& e) {
      throw Fail(key, e.message());
    }
  }

  Dataset Open(const std::string& key, const std::string& expected) const {
    if (!Has(key)) throw Fail(key, "missing dataset (expected " + expected + ")");
    Dataset d = h5::OpenDataset(group_.get(), key);
    if (!d.id.ok()) throw Fail(key, "not a dataset (expected " + expected + ")");
    return d;
  }

  // All elements, converted by HDF5 to `mem_type` (e.g. float64 or int64 -> float).
  template <class T>
  std::vector<T> Read(const Dataset& d, hid_t mem_type, const std::string& key) const {
    if (!d.DimsFitStoredData()) {
      throw Fail(key, d.Describe() + " is larger than the data stored for it (damaged file?)");
    }
    std::vector<T> out(d.NumElements());
    if (!d.ReadAll(mem_type, out.data())) {
      throw Fail(key, "cannot read " + d.Describe() + " (damaged file?)");
    }
    return out;
  }

  // One number per step ([T] or [T, 1]), for rewards and dones.
  std::vector<float> ReadPerStep(const std::string& key, int64_t num_steps) const {
    Dataset d = Open(key, "a number per step, [T]");
    bool shape_ok = (d.dims.size() == 1 || (d.dims.size() == 2 && d.dims[1] == 1)) &&
                    !d.dims.empty() && d.dims[0] == static_cast<hsize_t>(num_steps);
    if (shape_ok && d.cls == H5T_ENUM && d.bytes == 1) {
      // h5py stores numpy bool as an int8 enum, which HDF5 will not convert to float.
      Handle native(H5Tget_native_type(d.type.get(), H5T_DIR_ASCEND), H5Tclose);
      std::vector<uint8_t> raw = Read<uint8_t>(d, native.get(), key);
      return {raw.begin(), raw.end()};
    }
    if (!shape_ok || (d.cls != H5T_FLOAT && d.cls != H5T_INTEGER)) {
      throw Fail(key, "expected a number per step, [T] with T = " + std::to_string(num_steps) +
                          " (the length of actions), got " + d.Describe());
    }
    return Read<float>(d, H5T_NATIVE_FLOAT, key);
  }

  // LIBERO puts a JSON "problem_info" attribute on data/ (or the root); other writers a plain
  // "language_instruction" attribute on the demo, data/ or the root.
  std::string LanguageInstruction() const {
    try {
      for (hid_t obj : {data_.get(), file_.get()}) {
        std::optional<std::string> info = h5::ReadStringAttr(obj, "problem_info");
        if (!info) continue;
        json j = json::parse(*info, nullptr, /*allow_exceptions=*/false);
        Check(!j.is_discarded(), "attribute 'problem_info' is not valid JSON");
        if (j.is_object() && j.contains("language_instruction") &&
            j["language_instruction"].is_string()) {
          return j["language_instruction"].get<std::string>();
        }
      }
      for (hid_t obj : {group_.get(), data_.get(), file_.get()}) {
        if (auto text = h5::ReadStringAttr(obj, "language_instruction")) return *text;
      }
    } catch (const Error& e) {
      throw Fail("", e.message());
    }
    return "";
  }

 private:
  std::string path_;
  int64_t demo_;
  Handle file_, data_, group_;
};

// Image sides wmkit accepts from HDF5: an empty image has no pixels to encode, and larger sides
// than this are damage, not cameras.
constexpr hsize_t kMaxImageSide = 16384;
bool ImageSide(hsize_t side) { return side >= 1 && side <= kMaxImageSide; }

void ReadImages(const DemoReader& r, const std::string& camera, bool read_depth, RawDemo& raw) {
  std::vector<std::string> obs = r.Children("obs");
  raw.camera = camera.empty() ? ChooseCamera(obs) : camera;
  if (raw.camera.empty()) {
    std::string found;
    for (const auto& k : obs) found += (found.empty() ? "" : ", ") + k;
    throw r.Fail("obs",
                 "no camera dataset: none of agentview_rgb, agentview_image, image, *_rgb, "
                 "*_image (found: " +
                     (found.empty() ? "nothing" : found) + "); name one with the camera option");
  }
  std::string key = "obs/" + raw.camera;
  const std::string expected = "uint8 [T, H, W, 3], T = " + std::to_string(raw.num_steps) +
                               ", 1 <= H, W <= " + std::to_string(kMaxImageSide);
  Dataset rgb = r.Open(key, expected);
  if (!rgb.IsUnsignedInt(1) || rgb.dims.size() != 4 || rgb.dims[3] != 3 ||
      rgb.dims[0] != static_cast<hsize_t>(raw.num_steps) || !ImageSide(rgb.dims[1]) ||
      !ImageSide(rgb.dims[2])) {
    throw r.Fail(key, "expected " + expected + ", got " + rgb.Describe());
  }
  raw.height = static_cast<int>(rgb.dims[1]), raw.width = static_cast<int>(rgb.dims[2]);
  raw.rgb = r.Read<uint8_t>(rgb, H5T_NATIVE_UINT8, key);

  std::string depth_key = key + "_depth";
  if (!read_depth || !r.Has(depth_key)) return;
  Dataset depth = r.Open(depth_key, "uint16 [T, H, W]");
  bool rank_ok = depth.dims.size() == 3 || (depth.dims.size() == 4 && depth.dims[3] == 1);
  if (!depth.IsUnsignedInt(2) || !rank_ok || depth.dims[0] != static_cast<hsize_t>(raw.num_steps) ||
      !ImageSide(depth.dims[1]) || !ImageSide(depth.dims[2])) {
    throw r.Fail(depth_key,
                 "expected uint16 [T, H, W] or [T, H, W, 1], T = " + std::to_string(raw.num_steps) +
                     ", 1 <= H, W <= " + std::to_string(kMaxImageSide) + ", got " +
                     depth.Describe() + "; pass --hdf5-no-depth to ignore depth");
  }
  raw.depth_height = static_cast<int>(depth.dims[1]);
  raw.depth_width = static_cast<int>(depth.dims[2]);
  raw.depth = r.Read<uint16_t>(depth, H5T_NATIVE_UINT16, depth_key);
}

RawDemo ReadDemo(const EpisodeRef& ref, const std::string& camera, bool read_depth) {
  h5::Lock lock;
  DemoReader r(ref);
  RawDemo raw;
  const std::string expected =
      "float32/float64 [T, D], 1 <= D <= " + std::to_string(kMaxActionDim) +
      " action values per step";
  Dataset actions = r.Open("actions", expected);
  if (actions.cls != H5T_FLOAT || actions.dims.size() != 2 || actions.dims[1] < 1 ||
      actions.dims[1] > static_cast<hsize_t>(kMaxActionDim)) {
    throw r.Fail("actions", "expected " + expected + ", got " + actions.Describe());
  }
  raw.num_steps = static_cast<int64_t>(actions.dims[0]);
  raw.action_dim = static_cast<int64_t>(actions.dims[1]);
  if (raw.num_steps == 0) throw r.Fail("actions", "demo has no steps ([0, D])");
  raw.actions = r.Read<float>(actions, H5T_NATIVE_FLOAT, "actions");
  if (r.Has("rewards")) raw.rewards = r.ReadPerStep("rewards", raw.num_steps);
  if (r.Has("dones")) raw.dones = r.ReadPerStep("dones", raw.num_steps);
  ReadImages(r, camera, read_depth, raw);
  raw.language_instruction = r.LanguageInstruction();
  return raw;
}

// image_codec offers 8-bit RGB only; a 16-bit single-channel PNG keeps depth values exact.
std::string EncodePngDepth(const uint16_t* pixels, int height, int width) {
  cv::Mat img(height, width, CV_16UC1, const_cast<uint16_t*>(pixels));
  std::vector<uchar> out;
  Check(cv::imencode(".png", img, out), "cannot encode depth frame as PNG");
  return {out.begin(), out.end()};
}

std::vector<std::string> ListDemos(const std::string& path) {
  h5::Lock lock;
  Handle file = h5::OpenFile(path);
  Handle data = OpenDataGroup(file.get(), path);
  try {
    return h5::ChildNames(data.get());
  } catch (const Error& e) {
    throw e.WithFile(path).WithKey("data");
  }
}

// The demo numbers of data/'s members named demo_N, packed for the trip from the child process.
// Other members (e.g. a "mask" group) are not episodes.
std::string PackDemoNumbers(const std::vector<std::string>& names) {
  std::vector<int64_t> numbers;
  for (const auto& name : names) {
    if (auto n = DemoNumber(name)) numbers.push_back(*n);
  }
  std::string packed;
  bytes::Put(packed, numbers);
  return packed;
}

// `read()` in a child process under the isolation's limits (in this process when it is off);
// a child that dies means libhdf5 failed on the file `where` names.
std::string ReadIsolated(const Hdf5Isolation& isolation, const std::function<std::string()>& read,
                         const ErrorContext& where) {
  if (!isolation.enabled) return read();
  ChildOutcome outcome = RunInChildProcess(read, isolation.limits);
  if (outcome.output) return std::move(*outcome.output);
  throw Error("libhdf5 " + outcome.failure +
                  " while reading it: the file is damaged (libhdf5 keeps no checksums on most "
                  "metadata, so damage can crash it or make it allocate or loop without end), or "
                  "it needs more than --hdf5-memory-limit-mb / --hdf5-cpu-limit-s allow",
              where);
}

// (path, path relative to the input) of every input file, sorted by relative path.
std::vector<std::pair<std::string, std::string>> FindInputFiles(const std::string& input) {
  Check(fs::exists(input), "input does not exist", {input});
  if (!fs::is_directory(input)) return {{input, fs::path(input).filename().string()}};
  std::vector<std::pair<std::string, std::string>> files;
  for (const auto& entry : fs::recursive_directory_iterator(input)) {
    std::string ext = entry.path().extension().string();
    std::transform(ext.begin(), ext.end(), ext.begin(),
                   [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
    if (!entry.is_regular_file() || (ext != ".hdf5" && ext != ".h5")) continue;
    files.emplace_back(entry.path().string(), fs::relative(entry.path(), input).generic_string());
  }
  Check(!files.empty(), "no .hdf5 or .h5 files under this directory", {input});
  std::sort(files.begin(), files.end(),
            [](const auto& a, const auto& b) { return a.second < b.second; });
  return files;
}

}  // namespace

Hdf5Source::Hdf5Source(std::string input, std::string camera, bool depth, Hdf5Isolation isolation,
                       std::string action_space)
    : input_(std::move(input)),
      camera_(std::move(camera)),
      depth_(depth),
      isolation_(isolation),
      action_space_(std::move(action_space)) {}

std::string Hdf5Source::dataset_name() const {
  fs::path p = fs::absolute(input_).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();  // "dir/" normalises to a trailing slash
  return fs::is_directory(p) ? p.filename().string() : p.stem().string();
}

std::vector<EpisodeRef> Hdf5Source::ListEpisodes(std::vector<shard::SkippedEpisode>* damaged) {
  std::vector<EpisodeRef> refs;
  for (const auto& [path, rel_path] : FindInputFiles(input_)) {
    std::vector<int64_t> demos;
    try {
      const std::string listed = ReadIsolated(
          isolation_, [&file = path] { return PackDemoNumbers(ListDemos(file)); }, {.file = path});
      bytes::Reader(listed).Take(demos);
    } catch (const Error& e) {
      if (damaged == nullptr) throw;
      damaged->push_back({rel_path, 0, e.message()});
      continue;
    }
    std::sort(demos.begin(), demos.end());  // demo_2 before demo_10
    for (int64_t n : demos) refs.push_back({path, rel_path, n});
  }
  return refs;
}

Episode Hdf5Source::Load(const EpisodeRef& ref) const {
  RawDemo raw = UnpackRawDemo(
      ReadIsolated(isolation_, [&] { return PackRawDemo(ReadDemo(ref, camera_, depth_)); },
                   {.file = ref.path, .record = ref.record, .record_label = "demo"}));
  const size_t T = static_cast<size_t>(raw.num_steps);
  Episode ep;
  StartEpisode(ep, ref);
  ep.language_instruction = std::move(raw.language_instruction);
  ep.num_steps = raw.num_steps;
  SetActions(ep, std::move(raw.actions), raw.action_dim, action_space_,
             {.file = ref.path, .record = ref.record, .record_label = "demo", .key = "actions"});
  ep.rewards = raw.rewards.empty() ? std::vector<float>(T, 0.0f) : std::move(raw.rewards);
  // Only the last step's done counts: robomimic's done_mode 2 also sets dones at mid-episode
  // success steps, which do not end the episode.
  SetBoundaryFlags(ep, !raw.dones.empty() && raw.dones[T - 1] != 0.0f);

  auto check = [&](EncodedFrames& frames, const std::string& key) {
    try {
      CheckFrames(frames, /*full=*/false);
    } catch (const Error& e) {
      throw e.WithFile(ref.path).WithRecord(ref.record, "demo").WithKey(key);
    }
  };
  EncodedFrames& image = ep.images["image"];
  image.encoding = "png";
  const size_t frame_bytes = static_cast<size_t>(raw.height) * raw.width * 3;
  for (size_t t = 0; t < T; ++t) {
    image.frames.push_back(EncodePngRgb(&raw.rgb[t * frame_bytes], raw.height, raw.width, 3));
  }
  check(image, "obs/" + raw.camera);
  if (!raw.depth.empty()) {
    EncodedFrames& depth = ep.images["depth"];
    depth.encoding = "png";
    const size_t frame_size = static_cast<size_t>(raw.depth_height) * raw.depth_width;
    for (size_t t = 0; t < T; ++t) {
      depth.frames.push_back(
          EncodePngDepth(&raw.depth[t * frame_size], raw.depth_height, raw.depth_width));
    }
    check(depth, "obs/" + raw.camera + "_depth");
  }
  return ep;
}

json Hdf5Source::Describe() const {
  json settings = {{"camera", camera_.empty() ? "auto" : camera_}, {"depth", depth_}};
  if (!action_space_.empty()) settings["action_space"] = action_space_;
  return settings;
}

}  // namespace wm::ingest

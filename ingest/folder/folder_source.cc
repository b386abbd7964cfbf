#include "ingest/folder/folder_source.h"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>
#include <string_view>
#include <utility>

#include "core/error.h"
#include "core/shard/dataset_index.h"
#include "ingest/image_codec.h"

namespace wm::ingest {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

bool IsDigit(char c) { return std::isdigit(static_cast<unsigned char>(c)) != 0; }

std::string_view StripLeadingZeros(std::string_view digits) {
  while (digits.size() > 1 && digits.front() == '0') digits.remove_prefix(1);
  return digits;
}

// Natural order: runs of digits compare by value, so "frame_9" sorts before "frame_10".
bool NaturalLess(std::string_view a, std::string_view b) {
  size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    if (!IsDigit(a[i]) || !IsDigit(b[j])) {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i, ++j;
      continue;
    }
    size_t i0 = i, j0 = j;
    while (i < a.size() && IsDigit(a[i])) ++i;
    while (j < b.size() && IsDigit(b[j])) ++j;
    std::string_view x = StripLeadingZeros(a.substr(i0, i - i0));
    std::string_view y = StripLeadingZeros(b.substr(j0, j - j0));
    if (x.size() != y.size()) return x.size() < y.size();
    if (x != y) return x < y;
  }
  if (a.size() - i != b.size() - j) return a.size() - i < b.size() - j;
  return a < b;  // equal up to leading zeros ("f01" vs "f1"): any fixed order will do
}

std::string_view Trim(std::string_view s) {
  while (!s.empty() && (s.front() == ' ' || s.front() == '\t')) s.remove_prefix(1);
  while (!s.empty() && (s.back() == ' ' || s.back() == '\t')) s.remove_suffix(1);
  return s;
}

// The whole field must be one number; from_chars alone would accept "1.5abc" as 1.5.
bool ParseFloat(std::string_view field, float& out) {
  field = Trim(field);
  if (field.size() > 1 && field.front() == '+') field.remove_prefix(1);  // from_chars rejects '+'
  const char* end = field.data() + field.size();
  auto [ptr, ec] = std::from_chars(field.data(), end, out);
  return !field.empty() && ec == std::errc() && ptr == end;
}

std::vector<std::string_view> SplitFields(std::string_view line) {
  std::vector<std::string_view> fields;
  for (size_t start = 0;;) {
    size_t comma = line.find(',', start);
    fields.push_back(line.substr(start, comma - start));
    if (comma == std::string_view::npos) return fields;
    start = comma + 1;
  }
}

// The rows of a CSV file of numbers, flattened, `width` values each.
struct NumberRows {
  std::vector<float> values;
  size_t width = 0;
};

// Rows of `width` comma-separated numbers (0: as many as the first data row has, at most
// kMaxActionDim). A first row whose first field is not a number is a header and skipped; blank
// lines are skipped. Errors name the file and line.
NumberRows ReadNumberRows(const fs::path& path, size_t width) {
  std::ifstream in(path);
  Check(in.good(), "cannot open file", {path.string()});
  NumberRows rows{.width = width};
  const bool inferred = width == 0;
  std::string line;
  bool first_row = true;
  for (int64_t line_no = 1; std::getline(in, line); ++line_no) {
    if (!line.empty() && line.back() == '\r') line.pop_back();  // CRLF files
    if (Trim(line).empty()) continue;
    std::vector<std::string_view> fields = SplitFields(line);
    float value = 0;
    if (std::exchange(first_row, false) && !ParseFloat(fields[0], value)) continue;
    ErrorContext where{path.string(), line_no, "line"};
    if (rows.width == 0) {
      rows.width = fields.size();
      Check(rows.width <= kMaxActionDim,
            "expected at most " + std::to_string(kMaxActionDim) + " values per row, got " +
                std::to_string(rows.width),
            where);
    }
    Check(fields.size() == rows.width,
          "expected " + std::to_string(rows.width) + " comma-separated value" +
              (rows.width == 1 ? "" : "s") + (inferred ? " (as in the first row)" : "") + ", got " +
              std::to_string(fields.size()),
          where);
    for (std::string_view field : fields) {
      Check(ParseFloat(field, value), "'" + std::string(Trim(field)) + "' is not a number", where);
      rows.values.push_back(value);
    }
  }
  return rows;
}

std::string ReadBytes(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  Check(in.good(), "cannot open file", {path.string()});
  std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  Check(!in.bad(), "cannot read file", {path.string()});
  return bytes;
}

bool IsFrameFile(const fs::directory_entry& entry) {
  std::string ext = entry.path().extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return entry.is_regular_file() && (ext == ".png" || ext == ".jpg" || ext == ".jpeg");
}

// Frames in natural file-name order, bytes as stored.
EncodedFrames ReadFrames(const fs::path& dir) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(dir)) {
    if (IsFrameFile(entry)) names.push_back(entry.path().filename().string());
  }
  Check(!names.empty(), "episode has no frames (*.png, *.jpg, *.jpeg)", {dir.string()});
  std::sort(names.begin(), names.end(), NaturalLess);
  EncodedFrames frames;
  for (const auto& name : names) {
    std::string bytes = ReadBytes(dir / name);
    // Checked here as well as in CheckFrames so that the error names the frame's file.
    Check(!SniffEncoding(bytes).empty(), "frame is neither JPEG nor PNG", {(dir / name).string()});
    frames.frames.push_back(std::move(bytes));
  }
  return frames;
}

struct Meta {
  std::string language_instruction, policy_id;
  std::string action_space;  // empty: not said
  std::optional<int64_t> episode_seed;
  bool terminal = false;
};

// meta.json's `key` when present and not null; a value of another type is an error.
template <class T>
std::optional<T> MetaField(const json& meta, const char* key,
                           bool (json::*is_type)() const noexcept, const char* expected,
                           const fs::path& path) {
  auto it = meta.find(key);
  if (it == meta.end() || it->is_null()) return std::nullopt;
  Check(((*it).*is_type)(), std::string("must be ") + expected + ", got " + it->dump(),
        {path.string(), std::nullopt, "", key});
  return it->get<T>();
}

Meta ReadMeta(const fs::path& path) {
  Meta meta;
  if (!fs::exists(path)) return meta;
  std::ifstream in(path);
  Check(in.good(), "cannot open file", {path.string()});
  json j = json::parse(in, nullptr, /*allow_exceptions=*/false);
  Check(!j.is_discarded() && j.is_object(), "not a JSON object", {path.string()});
  meta.language_instruction =
      MetaField<std::string>(j, "language_instruction", &json::is_string, "a string", path)
          .value_or("");
  meta.policy_id =
      MetaField<std::string>(j, "policy_id", &json::is_string, "a string", path).value_or("");
  meta.episode_seed =
      MetaField<int64_t>(j, "episode_seed", &json::is_number_integer, "an integer", path);
  meta.terminal =
      MetaField<bool>(j, "terminal", &json::is_boolean, "true or false", path).value_or(false);
  meta.action_space =
      MetaField<std::string>(j, "action_space", &json::is_string, "a string", path).value_or("");
  Check(meta.action_space.empty() || shard::IsKnownActionSpace(meta.action_space),
        "must be eef_delta, joint_position or other, got '" + meta.action_space + "'",
        {path.string(), std::nullopt, "", "action_space"});
  return meta;
}

}  // namespace

FolderSource::FolderSource(std::string input, std::string action_space)
    : input_(std::move(input)), action_space_(std::move(action_space)) {}

nlohmann::json FolderSource::Describe() const {
  nlohmann::json settings = nlohmann::json::object();
  if (!action_space_.empty()) settings["action_space"] = action_space_;
  return settings;
}

std::string FolderSource::dataset_name() const {
  fs::path p = fs::absolute(input_).lexically_normal();
  if (p.filename().empty()) p = p.parent_path();  // "dir/" normalises to a trailing slash
  return p.filename().string();
}

std::vector<EpisodeRef> FolderSource::ListEpisodes(
    std::vector<shard::SkippedEpisode>* /*damaged*/) {
  Check(fs::is_directory(input_),
        "input is not a directory (expected one subdirectory per episode)", {input_});
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(input_)) {
    std::string name = entry.path().filename().string();
    if (entry.is_directory() && !name.starts_with(".")) names.push_back(std::move(name));
  }
  Check(!names.empty(), "no episode subdirectories", {input_});
  std::sort(names.begin(), names.end(), NaturalLess);
  std::vector<EpisodeRef> refs;
  refs.reserve(names.size());
  for (const auto& name : names) refs.push_back({(fs::path(input_) / name).string(), name, 0});
  return refs;
}

Episode FolderSource::Load(const EpisodeRef& ref) const {
  const fs::path dir = ref.path;
  Episode ep;
  StartEpisode(ep, ref);

  EncodedFrames& image = ep.images["image"];
  image = ReadFrames(dir);
  try {
    CheckFrames(image, /*full=*/false);
  } catch (const Error& e) {
    throw e.WithFile(dir.string()).WithKey("image");
  }
  const size_t T = image.frames.size();
  ep.num_steps = static_cast<int64_t>(T);

  Meta meta = ReadMeta(dir / "meta.json");
  const fs::path actions_path = dir / "actions.csv";
  Check(fs::exists(actions_path),
        "episode has no actions.csv (T rows of D comma-separated numbers, e.g. 7)", {dir.string()});
  NumberRows actions = ReadNumberRows(actions_path, /*width=*/0);
  const size_t rows = actions.values.size() / std::max<size_t>(actions.width, 1);
  Check(rows == T,
        "has " + std::to_string(rows) + " action rows but the episode has " + std::to_string(T) +
            " frames (one row per frame)",
        {actions_path.string()});
  // --action-space says what the user knows of the whole dataset, so it outranks meta.json's.
  SetActions(ep, std::move(actions.values), static_cast<int64_t>(actions.width),
             action_space_.empty() ? meta.action_space : action_space_, {actions_path.string()});

  const fs::path rewards_path = dir / "rewards.csv";
  if (fs::exists(rewards_path)) {
    ep.rewards = ReadNumberRows(rewards_path, 1).values;
    Check(ep.rewards.size() == T,
          "has " + std::to_string(ep.rewards.size()) + " rewards but the episode has " +
              std::to_string(T) + " frames (one reward per frame)",
          {rewards_path.string()});
  } else {
    ep.rewards.assign(T, 0.0f);
  }

  ep.language_instruction = std::move(meta.language_instruction);
  ep.policy_id = std::move(meta.policy_id);
  ep.episode_seed = meta.episode_seed;

  // A folder cannot say whether the episode reached a terminal state; meta.json must.
  SetBoundaryFlags(ep, meta.terminal);
  return ep;
}

}  // namespace wm::ingest

#include "ingest/suggest_mapping.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <vector>

#include "core/error.h"
#include "ingest/rlds/tfds_dataset.h"

namespace wm::ingest {
namespace fs = std::filesystem;
using nlohmann::ordered_json;

namespace {

// A YAML scalar: plain when safe, else JSON's double-quoted form (valid YAML).
std::string Scalar(const std::string& s) {
  const bool plain = !s.empty() && std::all_of(s.begin(), s.end(), [](char c) {
    return std::isalnum(static_cast<unsigned char>(c)) || c == '_' || c == '.' || c == '/' ||
           c == '-';
  });
  return plain ? s : ordered_json(s).dump();
}

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool Contains(const std::string& s, const std::string& part) {
  return Lower(s).find(part) != std::string::npos;
}

std::string Joined(const std::vector<std::string>& v, size_t most = 8) {
  std::string out;
  for (size_t i = 0; i < v.size() && i < most; ++i) out += (i ? ", " : "") + v[i];
  if (v.size() > most) out += ", ... (" + std::to_string(v.size()) + " in all)";
  return out;
}

// The camera: the first candidate whose last path part is exactly `image`, else the first.
std::string ChooseCamera(const std::vector<std::string>& cameras, std::ostringstream& note) {
  if (cameras.empty()) return "";
  auto exact = std::find_if(cameras.begin(), cameras.end(), [](const std::string& k) {
    return k.size() >= 5 && k.compare(k.size() - 5, 5, "image") == 0;
  });
  const std::string chosen = exact != cameras.end() ? *exact : cameras.front();
  if (cameras.size() > 1) {
    note << "# UNCERTAIN camera: " << cameras.size() << " cameras (" << Joined(cameras)
         << "); took " << chosen << "\n";
  }
  return chosen;
}

// ---- LeRobot: meta/info.json features

// Every string in a feature's `names` (a list, or {"motors": [...]}-style groups).
void CollectNames(const ordered_json& j, std::vector<std::string>& out) {
  if (j.is_string()) out.push_back(j.get<std::string>());
  if (j.is_array() || j.is_object()) {
    for (const auto& v : j) CollectNames(v, out);
  }
}

// eef_delta only when the names say delta; joint names -> joint_position; else other.
std::string GuessActionSpace(const std::vector<std::string>& names, std::string& why) {
  static const std::vector<std::string> joint_words = {
      "joint", "shoulder", "elbow", "wrist", "hip",   "knee", "ankle",
      "waist", "finger",   "pinky", "thumb", "motor", "hand"};
  static const std::vector<std::string> pose_words = {"x",    "y",     "z",   "dx", "dy", "dz",
                                                      "roll", "pitch", "yaw", "rx", "ry", "rz"};
  int joint = 0, pose = 0, delta = 0;
  for (const auto& n : names) {
    const std::string l = Lower(n);
    if (std::any_of(joint_words.begin(), joint_words.end(),
                    [&](const std::string& w) { return l.find(w) != std::string::npos; })) {
      ++joint;
    }
    if (std::find(pose_words.begin(), pose_words.end(), l) != pose_words.end() ||
        l.find("eef") != std::string::npos || l.find("ee_") != std::string::npos) {
      ++pose;
    }
    if (l.find("delta") != std::string::npos) ++delta;
  }
  if (names.empty()) {
    why = "UNCERTAIN action_space: info.json names no action dimensions";
    return "other";
  }
  if (delta > 0 && pose + delta >= 3) {
    why = "action_space from names with 'delta'; check the rotation is roll-pitch-yaw";
    return "eef_delta";
  }
  if (pose >= 3) {
    why =
        "UNCERTAIN action_space: end-effector names without 'delta' (an absolute pose?); "
        "eef_delta only if these are deltas";
    return "other";
  }
  if (2 * joint >= static_cast<int>(names.size())) {
    why =
        "UNCERTAIN action_space: joint names, taken as position targets (say other for "
        "velocities or torques)";
    return "joint_position";
  }
  why = "UNCERTAIN action_space: the names say neither joints nor end-effector deltas";
  return "other";
}

std::string SuggestLeRobot(const std::string& root) {
  const fs::path file = fs::path(root) / "meta" / "info.json";
  std::ifstream in(file);
  Check(in.good(), "not a LeRobot dataset: cannot open meta/info.json", {.file = file.string()});
  const ordered_json info = ordered_json::parse(in, nullptr, /*allow_exceptions=*/false);
  Check(info.is_object() && info.contains("features") && info["features"].is_object(),
        "no \"features\" object", {.file = file.string()});
  const ordered_json& features = info["features"];
  auto has = [&](const std::string& k) { return features.contains(k); };
  auto first_of = [&](std::initializer_list<const char*> keys) -> std::string {
    for (const char* k : keys) {
      if (has(k)) return k;
    }
    return "";
  };
  std::vector<std::string> cameras;
  for (const auto& [k, f] : features.items()) {
    if (f.value("dtype", "") == "video") cameras.push_back(k);
  }
  std::ostringstream note, out;
  out << "# Suggested by wm-ingest --suggest-mapping from " << file.string() << " (LeRobot "
      << info.value("codebase_version", "?") << "). Review the lines marked UNCERTAIN, then save\n"
      << "# as configs/lerobot/<dataset dir name>.yaml or pass it with --mapping. Fields: "
         "docs/lerobot-mapping.md.\n";
  const std::string camera = ChooseCamera(cameras, note);
  if (cameras.empty()) note << "# UNCERTAIN camera: no video feature (wmkit reads video cameras)\n";
  std::string action = first_of({"action", "actions"});
  if (action.empty()) {
    for (const auto& [k, f] : features.items()) {
      if (action.empty() && Contains(k, "action")) action = k;
    }
    note << "# UNCERTAIN action: no feature named action or actions"
         << (action.empty() ? "; fill it in" : "; took " + action) << "\n";
  }
  std::vector<std::string> names;
  int64_t width = 1;
  if (!action.empty()) {
    CollectNames(features[action].value("names", ordered_json()), names);
    for (const auto& d : features[action].value("shape", ordered_json::array())) {
      if (d.is_number_integer()) width *= d.get<int64_t>();
    }
  }
  std::string why;
  const std::string space = GuessActionSpace(names, why);
  out << note.str();
  out << "camera: " << (camera.empty() ? "null" : Scalar(camera)) << "\n";
  if (!action.empty()) {
    out << "# action: " << width << " values per step"
        << (names.empty() ? "" : ", in this order: " + Joined(names, 32)) << "\n";
  }
  out << "action: " << (action.empty() ? "action" : Scalar(action)) << "\n";
  out << "# " << why << "\n";
  out << "action_space: " << space << "\n";
  const std::string state = first_of({"observation.state", "state", "observation.states"});
  out << "state: " << (state.empty() ? "null" : Scalar(state)) << "\n";
  for (const char* k : {"timestamp", "frame_index", "episode_index", "task_index"}) {
    if (!has(k)) out << "# UNCERTAIN " << k << ": info.json declares no such feature\n";
    out << k << ": " << k << "\n";
  }
  const std::string reward = first_of({"next.reward", "reward"});
  const std::string done = first_of({"next.done", "is_terminal", "next.terminated"});
  out << "reward: " << (reward.empty() ? "null" : Scalar(reward)) << "\n";
  out << "is_terminal: " << (done.empty() ? "null" : Scalar(done)) << "\n";
  out << "# The instruction is each episode's task text (meta/tasks), whatever the mapping.\n";
  out << "tolerance_s: 1.0e-4\n";
  return out.str();
}

// ---- RLDS: features.json through OpenTfdsDataset

// One tensor steps/action says nothing of what its values are: 7 are taken as the canonical
// delta, any other width is kept whole as `other` (dropping values is the user's decision), and
// the builder's own description is quoted so the user can check either guess.
void SuggestFlatAction(const rlds::FeatureSpec& action, std::ostream& out) {
  const int64_t n = action.ElementSize();
  std::string said = action.description;
  std::replace_if(
      said.begin(), said.end(), [](char c) { return c == '\n' || c == '\r'; }, ' ');
  out << "# UNCERTAIN action: one " << n << "-value tensor steps/action; "
      << (n == 7 ? "taken as xyz, rpy deltas and gripper in that order"
                 : "kept whole as action_space other (if its first 7 values are xyz, rpy deltas "
                   "and gripper, select: [0, 1, 2, 3, 4, 5, 6] and drop action_space)")
      << "; the dataset says: " << (said.empty() ? "nothing" : "'" + said + "'") << "\n";
  out << "action:\n  - key: steps/action\n";
  if (n != 7) out << "action_space: other\n";
}

std::string SuggestRlds(const std::string& input) {
  const rlds::TfdsDataset d = rlds::OpenTfdsDataset(input);
  std::vector<std::string> cameras, texts;
  for (const auto& [k, f] : d.features) {
    if (f.per_step && f.tfds_class == "Image" && !Contains(k, "depth") && !Contains(k, "seg")) {
      cameras.push_back(k);
    }
    if (f.tfds_class == "Text") texts.push_back(k);
  }
  auto has = [&](const std::string& k) { return d.features.count(k) > 0; };
  std::ostringstream note, out;
  out << "# Suggested by wm-ingest --suggest-mapping from " << d.dir << "/features.json (" << d.name
      << " " << d.version << "). Review the lines marked UNCERTAIN, then save as\n"
      << "# configs/datasets/" << d.name << ".yaml. Fields: docs/dataset-mapping.md.\n";
  const std::string image = ChooseCamera(cameras, note);
  if (image.empty()) note << "# UNCERTAIN image: no per-step Image feature; fill it in\n";
  out << note.str() << "dataset: " << Scalar(d.name) << "\n"
      << "image: " << Scalar(image.empty() ? "steps/observation/image" : image) << "\n";
  // The action: the canonical 7-dim end-effector delta where the features give one.
  out << "# action: the canonical 7 dims (dx, dy, dz, droll, dpitch, dyaw, gripper; action space "
         "eef_delta), or with action_space another width kept as it is\n";
  std::string gripper;
  for (const auto& [k, f] : d.features) {
    if (gripper.empty() && k.rfind("steps/action/", 0) == 0 && Contains(k, "gripper") &&
        f.ElementSize() == 1) {
      gripper = k;
    }
  }
  if (has("steps/action/world_vector") && has("steps/action/rotation_delta") && !gripper.empty()) {
    out << "action:\n  - key: steps/action/world_vector\n  - key: steps/action/rotation_delta\n";
    if (Contains(gripper, "open")) {
      out << "  # UNCERTAIN gripper: '" << gripper << "' reads as 1 = open; mapped to 1 = closed\n";
      out << "  - key: " << gripper << "\n    scale: -1\n    offset: 1\n";
    } else {
      out << "  # check the gripper's sign: wmkit wants 1 = closed\n  - key: " << gripper << "\n";
    }
  } else if (has("steps/action")) {
    SuggestFlatAction(d.features.at("steps/action"), out);
  } else {
    out << "# UNCERTAIN action: no world_vector + rotation_delta + gripper and no steps/action; "
           "fill in parts summing to 7 (zeros: N pads)\n";
    out << "action:\n  - zeros: 7\n";
  }
  out << "reward: " << (has("steps/reward") ? "steps/reward" : "null") << "\n";
  if (has("steps/discount")) out << "discount: steps/discount\n";
  std::string instruction;
  for (const auto& k : texts) {
    if (instruction.empty() && Contains(k, "instruction")) instruction = k;
  }
  if (instruction.empty() && !texts.empty()) {
    instruction = texts.front();
    out << "# UNCERTAIN language_instruction: no Text feature named *instruction*; took "
        << instruction << " of " << Joined(texts) << "\n";
  }
  out << "language_instruction: " << (instruction.empty() ? "null" : Scalar(instruction)) << "\n";
  return out.str();
}

}  // namespace

std::string SuggestMapping(const std::string& format, const std::string& input) {
  if (format == "lerobot") return SuggestLeRobot(input);
  if (format == "rlds") return SuggestRlds(input);
  throw Error("--suggest-mapping reads rlds and lerobot datasets, not --format " + format);
}

}  // namespace wm::ingest

#pragma once
// The canonical robot episode every reader produces and every shard stores. Images stay as
// their encoded bytes (JPEG/PNG); numeric streams are flat row-major arrays of T rows.
#include <array>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

namespace wm {

inline constexpr int kActionDim = 7;  // Δx, Δy, Δz, Δroll, Δpitch, Δyaw, gripper
inline constexpr std::array<const char*, kActionDim> kActionNames = {
    "dx", "dy", "dz", "droll", "dpitch", "dyaw", "gripper"};
inline constexpr int kMaxActionDim = 4096;  // a bound for damaged input, far above real robots

struct EncodedFrames {
  std::string encoding;                     // "jpeg" or "png"
  std::string dtype = "uint8";              // decoded pixel type: "uint8", or "uint16" (depth)
  int height = 0, width = 0, channels = 0;  // of every decoded frame
  std::vector<std::string> frames;          // one encoded image per step
};

struct Episode {
  std::string episode_key;    // "<input file relative to input root>#<record>"
  std::string source_file;    // relative to the input root
  int64_t source_record = 0;  // record / demo / folder index within source_file
  std::string language_instruction;
  std::string policy_id;  // which policy produced it ("" when unknown)
  std::optional<int64_t> episode_seed;

  int64_t num_steps = 0;  // T
  // D, values per action: 7 (kActionNames) for the canonical end-effector delta that RLDS, HDF5
  // and folder sources produce; a joint-space LeRobot dataset keeps its own width (G1: 26).
  int64_t action_dim = kActionDim;
  std::string action_space = "eef_delta";               // "eef_delta", "joint_position" or "other"
  std::vector<float> actions;                           // [T, D]
  std::vector<float> rewards;                           // [T]
  std::vector<float> discounts;                         // [T], 1 when the source has none
  std::vector<uint8_t> is_first, is_last, is_terminal;  // [T], 0/1
  std::map<std::string, EncodedFrames> images;  // "image" always; "depth", "segmentation" optional
};

}  // namespace wm

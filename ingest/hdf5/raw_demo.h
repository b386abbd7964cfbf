#pragma once
// One robomimic/LIBERO demo as libhdf5 hands it over, before PNG encoding, and its byte form for
// the trip from the child process that reads the file (hdf5_source.cc) back to wm-ingest.
#include <cstdint>
#include <string>
#include <vector>

namespace wm::ingest {

struct RawDemo {
  int64_t num_steps = 0, action_dim = 0;
  std::vector<float> actions, rewards, dones;  // actions [T, action_dim]; rewards / dones empty
                                               // when absent
  std::string camera;
  std::vector<uint8_t> rgb;     // [T, H, W, 3]
  std::vector<uint16_t> depth;  // [T, H, W], empty when absent
  int height = 0, width = 0, depth_height = 0, depth_width = 0;
  std::string language_instruction;
};

std::string PackRawDemo(const RawDemo& demo);
// Throws wm::Error when `packed` is not what PackRawDemo wrote.
RawDemo UnpackRawDemo(const std::string& packed);

}  // namespace wm::ingest

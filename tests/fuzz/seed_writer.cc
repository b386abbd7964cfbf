// fuzz_seed_writer: writes the seed corpora of tests/fuzz/corpus with wmkit's own writers (and
// the HDF5 C API for the robomimic layout). Seeds are tiny on purpose (fake 1-step-sized images,
// 2-3 steps) so the fuzzer mutates structure rather than pixels. The yaml_config seeds are
// copies of shipped configs and are not written here.
//
//   fuzz_seed_writer OUT_DIR   # writes OUT_DIR/<target>/<seed>; exit 0 ok, 1 error, 2 usage
#include <hdf5.h>

#include <cstdio>
#include <filesystem>
#include <fstream>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/shard/shard_writer.h"
#include "ingest/rlds/example.h"
#include "ingest/rlds/tfrecord.h"
#include "tests/core/test_util.h"
#include "tests/ingest/lerobot_v30_fixture.h"
#include "tests/ingest/parquet_writer.h"

namespace {
namespace fs = std::filesystem;
using namespace wm;

// An episode of `steps` steps with the features configs/datasets/fractal20220817_data.yaml reads.
std::string FractalExample(int steps) {
  rlds::ExampleBuilder b;
  std::vector<std::string> frames, text;
  std::vector<float> xyz, gripper, reward;
  std::vector<int64_t> first, last;
  for (int t = 0; t < steps; ++t) {
    frames.push_back(std::string("\xFF\xD8\xFF", 3) + "frame" + std::to_string(t));
    text.push_back("pick the can");
    for (int i = 0; i < 3; ++i) xyz.push_back(0.1f * static_cast<float>(t + i));
    gripper.push_back(t % 2 == 0 ? 1.0f : -1.0f);
    reward.push_back(t == steps - 1 ? 1.0f : 0.0f);
    first.push_back(t == 0);
    last.push_back(t == steps - 1);
  }
  b.AddBytes("steps/observation/image", frames);
  b.AddBytes("steps/observation/natural_language_instruction", text);
  b.AddFloats("steps/action/world_vector", xyz);
  b.AddFloats("steps/action/rotation_delta", xyz);
  b.AddFloats("steps/action/gripper_closedness_action", gripper);
  b.AddFloats("steps/reward", reward);
  b.AddInt64s("steps/is_first", first);
  b.AddInt64s("steps/is_last", last);
  b.AddInt64s("steps/is_terminal", last);
  return b.Serialize();
}

void WriteRlds(const fs::path& out) {
  WriteFileAtomically((out / "example" / "fractal_2_steps.pb").string(), FractalExample(2));
  rlds::TfRecordWriter writer((out / "tfrecord" / "two_records.tfrecord").string());
  writer.Write(FractalExample(1));
  writer.Write(FractalExample(2));
  writer.Close();
}

void WriteShard(const fs::path& out) {
  shard::ShardWriter writer((out / "shard" / "two_episodes.wms").string());
  writer.Append(test::MakeEpisode(2, 1, "a"));
  Episode with_depth = test::MakeEpisode(3, 2, "b");
  EncodedFrames& depth = with_depth.images["depth"];
  depth.encoding = "png";
  depth.dtype = "uint16";
  depth.height = depth.width = 4, depth.channels = 1;
  depth.frames.assign(3, std::string("\x89PNG\r\n\x1a\n", 8));
  writer.Append(with_depth);
  writer.Finish();
}

// index.json, a NUL byte, part-00000.wmtok: the input format of tokens_fuzz.cc.
// Two seeds: the canonical 7-dim action (index version 1) and 6-dim joint actions (version 2).
void WriteTokens(const fs::path& out) {
  for (const auto& [name, action_dim] :
       {std::pair{"two_episodes.bin", 7}, {"joint_actions.bin", 6}}) {
    test::TempDir dir;
    test::MakeTokenDataset(dir.path().string(), 2, 1, 2, 2, 16, 7, action_dim);
    WriteFileAtomically(
        (out / "tokens" / name).string(),
        ReadFile(dir / "index.json") + std::string(1, '\0') + ReadFile(dir / "part-00000.wmtok"));
  }
}

void WriteHdf5Dataset(hid_t loc, const char* name, hid_t type, std::vector<hsize_t> dims,
                      const void* data) {
  hid_t lcpl = H5Pcreate(H5P_LINK_CREATE);
  H5Pset_create_intermediate_group(lcpl, 1);
  hid_t space = H5Screate_simple(static_cast<int>(dims.size()), dims.data(), nullptr);
  hid_t dset = H5Dcreate2(loc, name, type, space, lcpl, H5P_DEFAULT, H5P_DEFAULT);
  Check(dset >= 0 && H5Dwrite(dset, type, H5S_ALL, H5S_ALL, H5P_DEFAULT, data) >= 0,
        "cannot write HDF5 dataset", {.key = name});
  H5Dclose(dset);
  H5Sclose(space);
  H5Pclose(lcpl);
}

// data/demo_0 with 2 steps of 4x4 RGB + depth, as robomimic/LIBERO write it.
void WriteHdf5(const fs::path& out) {
  const std::string path = (out / "hdf5" / "one_demo.hdf5").string();
  hid_t file = H5Fcreate(path.c_str(), H5F_ACC_TRUNC, H5P_DEFAULT, H5P_DEFAULT);
  Check(file >= 0, "cannot create", {.file = path});
  hid_t data = H5Gcreate2(file, "data", H5P_DEFAULT, H5P_DEFAULT, H5P_DEFAULT);
  std::vector<float> actions(2 * 7, 0.5f);
  std::vector<double> rewards = {0, 1};
  std::vector<uint8_t> rgb(2 * 4 * 4 * 3, 128);
  std::vector<uint16_t> depth(2 * 4 * 4, 1000);
  WriteHdf5Dataset(data, "demo_0/actions", H5T_NATIVE_FLOAT, {2, 7}, actions.data());
  WriteHdf5Dataset(data, "demo_0/rewards", H5T_NATIVE_DOUBLE, {2}, rewards.data());
  WriteHdf5Dataset(data, "demo_0/dones", H5T_NATIVE_DOUBLE, {2}, rewards.data());
  WriteHdf5Dataset(data, "demo_0/obs/agentview_rgb", H5T_NATIVE_UINT8, {2, 4, 4, 3}, rgb.data());
  WriteHdf5Dataset(data, "demo_0/obs/agentview_rgb_depth", H5T_NATIVE_UINT16, {2, 4, 4},
                   depth.data());
  hid_t type = H5Tcopy(H5T_C_S1);
  H5Tset_size(type, H5T_VARIABLE);
  hid_t space = H5Screate(H5S_SCALAR);
  hid_t attr = H5Acreate2(data, "problem_info", type, space, H5P_DEFAULT, H5P_DEFAULT);
  const char* info = R"({"language_instruction": "open the drawer"})";
  H5Awrite(attr, type, &info);
  H5Aclose(attr);
  H5Sclose(space);
  H5Tclose(type);
  H5Gclose(data);
  H5Fclose(file);
}

// The episode list of the v3.0 fixture built from the Unitree G1 sample (3 episodes, one video
// key); skipped, keeping the committed seed, where ../shared has no sample.
void WriteLeRobotMeta(const fs::path& out) {
  const std::string sample = test::SamplesDir() + "/lerobot/unitree_g1_v21";
  if (!fs::exists(sample + "/meta/info.json")) {
    std::fprintf(stderr, "fuzz_seed_writer: no %s, lerobot_meta/ left as it is\n", sample.c_str());
    return;
  }
  const fs::path tmp = out / "lerobot_meta" / "tmp_v30";
  ingest::testing::WriteV30Fixture(sample, tmp.string());
  fs::copy_file(tmp / "meta/episodes/chunk-000/file-000.parquet",
                out / "lerobot_meta" / "unitree_g1_v30_episodes.parquet",
                fs::copy_options::overwrite_existing);
  fs::remove_all(tmp);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  try {
    const fs::path out = argv[1];
    for (const char* target :
         {"tfrecord", "example", "shard", "tokens", "hdf5", "parquet", "lerobot_meta"}) {
      fs::create_directories(out / target);
    }
    WriteRlds(out);
    WriteShard(out);
    WriteTokens(out);
    WriteHdf5(out);
    WriteLeRobotMeta(out);
    WriteFileAtomically((out / "parquet/list_two_row_groups.parquet").string(),
                        parquet::testing::ListColumnFile());
    WriteFileAtomically((out / "parquet/dictionary_page_v2.parquet").string(),
                        parquet::testing::OptionalDictionaryFile());
  } catch (const wm::Error& e) {
    std::fprintf(stderr, "fuzz_seed_writer: %s\n", e.what());
    return 1;
  }
  return 0;
}

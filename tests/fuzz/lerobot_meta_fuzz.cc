// Fuzz target: a LeRobot v3.0 episode list (meta/episodes/chunk-XXX/file-XXX.parquet) held in
// memory, read as ReadLeRobotMeta reads it, then every episode's data and video path formed.
// Damage must be a wm::Error; an accepted episode must keep the checked invariants.
#include <cstdlib>

#include "ingest/lerobot/lerobot_meta.h"
#include "ingest/parquet/parquet_file.h"
#include "tests/fuzz/fuzz_util.h"

using namespace wm;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::AcceptWmError([&] {
    const parquet::ParquetFile file =
        parquet::ParquetFile::FromBytes(std::string(fuzz::Bytes(data, size)), "in");
    ingest::LeRobotMeta meta;
    meta.many_episodes_per_file = true;
    meta.data_path = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet";
    meta.video_path = "videos/{video_key}/chunk-{chunk_index:03d}/file-{file_index:03d}.mp4";
    meta.video_keys = {"observation.images.cam_high"};
    ingest::ReadLeRobotEpisodesV30(file, "in", meta);
    for (const auto& e : meta.episodes) {
      if (e.length < 0 || e.to_row - e.from_row != e.length) std::abort();
      meta.DataPath(e);
      fuzz::AcceptWmError([&] {
        const ingest::LeRobotVideoSpan s = meta.VideoSpan(e, meta.video_keys[0]);
        if (!(s.from_s >= 0 && s.to_s > s.from_s)) std::abort();
        meta.VideoPath(e, meta.video_keys[0]);
      });
    }
  });
  return 0;
}

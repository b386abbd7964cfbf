// Fuzz target: a robomimic/LIBERO HDF5 file (ingest/hdf5/hdf5_source.h), listed and every demo
// loaded as `wm-ingest --format hdf5` does (auto camera, depth on), but in this process: the
// sanitizers must see what libhdf5 does, which wm-ingest confines to a child process. libhdf5
// itself is not instrumented, so the fuzzer steers by the coverage of wmkit's reader only.
#include "ingest/hdf5/hdf5_source.h"
#include "tests/fuzz/fuzz_util.h"

using namespace wm;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = fuzz::WriteTempFile("input.hdf5", fuzz::Bytes(data, size));
  ingest::Hdf5Source source(path, "", /*depth=*/true, {.enabled = false});
  std::vector<shard::SkippedEpisode> damaged;
  fuzz::AcceptWmError([&] { source.ListEpisodes(&damaged); });
  fuzz::AcceptWmError([&] {
    for (const ingest::EpisodeRef& ref : source.ListEpisodes(nullptr)) {
      fuzz::AcceptWmError([&] { source.Load(ref); });
    }
  });
  return 0;
}

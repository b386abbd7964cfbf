// Fuzz target: the TFRecord reader (ingest/rlds/tfrecord.h) on a whole file. Besides "no crash",
// the mapped reader and the positioned ReadTfRecordAt (used by RldsSource::Load) must agree on
// every record both accept.
#include <cstdlib>

#include "ingest/rlds/tfrecord.h"
#include "tests/fuzz/fuzz_util.h"

using namespace wm;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string path = fuzz::WriteTempFile("input.tfrecord", fuzz::Bytes(data, size));
  fuzz::AcceptWmError([&] {
    rlds::TfRecordReader reader(path);
    for (size_t k = 0; k < reader.num_records(); ++k) {
      fuzz::AcceptWmError([&] {
        std::string_view record = reader.Record(k);
        if (rlds::ReadTfRecordAt(path, reader.record_offsets()[k]) != record) std::abort();
      });
    }
  });
  fuzz::AcceptWmError([&] {
    for (uint64_t offset : rlds::ScanTfRecordOffsets(path, /*stop_at_damage=*/true)) {
      fuzz::AcceptWmError([&] { rlds::ReadTfRecordAt(path, offset); });
    }
  });
  // A positioned read of whatever the file starts with, as a stale offset would cause.
  fuzz::AcceptWmError([&] { rlds::ReadTfRecordAt(path, 0); });
  return 0;
}

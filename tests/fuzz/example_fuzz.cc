// Fuzz target: one serialized tf.train.Example (ingest/rlds/example.h), read through every
// accessor and mapped to an episode as `wm-ingest --format rlds` does, with the fractal sample's
// feature spec and mapping (tests/data/rlds, configs/datasets/fractal20220817_data.yaml).
#include "ingest/rlds/example.h"
#include "ingest/rlds/rlds_source.h"
#include "tests/fuzz/fuzz_util.h"

using namespace wm;

namespace {
const ingest::RldsSource& FractalSource() {
  static const ingest::RldsSource source(
      fuzz::SourceDir() + "/tests/data/rlds/fractal20220817_data/0.1.0", "train", "",
      fuzz::SourceDir() + "/configs");
  return source;
}
}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string bytes(fuzz::Bytes(data, size));
  fuzz::AcceptWmError([&] {
    rlds::Example example(bytes);
    for (const std::string& key : example.Keys()) {
      example.KindOf(key);
      example.Count(key);
      // Each accessor either returns the list or names the key and the expected list type.
      fuzz::AcceptWmError([&] { example.Bytes(key); });
      fuzz::AcceptWmError([&] { example.Floats(key); });
      fuzz::AcceptWmError([&] { example.Int64s(key); });
    }
  });
  fuzz::AcceptWmError([&] { FractalSource().MapExample(bytes); });
  return 0;
}

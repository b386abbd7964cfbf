// Fuzz target: the YAML loaders, fed the same text: the tokenizer and dynamics configs
// (tokenize/config.h, train/config.h, both over core/sectioned_yaml.h; their config.cc files
// need no LibTorch and are compiled in) and an RLDS dataset mapping
// (ingest/rlds/dataset_mapping.h, configs/datasets/*.yaml).
#include "ingest/rlds/dataset_mapping.h"
#include "tests/fuzz/fuzz_util.h"
#include "tokenize/config.h"
#include "train/config.h"

using namespace wm;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(fuzz::Bytes(data, size));
  fuzz::AcceptWmError([&] { tokenize::ParseTokenizerConfig(text, "fuzz.yaml"); });
  fuzz::AcceptWmError([&] { train::ParseDynamicsConfig(text, "fuzz.yaml"); });
  const std::string path = fuzz::WriteTempFile("mapping.yaml", text);
  fuzz::AcceptWmError([&] { rlds::LoadDatasetMapping(path).ToJson(); });
  return 0;
}

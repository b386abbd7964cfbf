// Fuzz target: the Parquet reader (ingest/parquet) on a whole file held in memory. Every column
// is read; damage must be a wm::Error, and an accepted column must have consistent rows.
#include <cstdlib>

#include "ingest/parquet/parquet_file.h"
#include "tests/fuzz/fuzz_util.h"

using namespace wm;

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  fuzz::AcceptWmError([&] {
    const parquet::ParquetFile file =
        parquet::ParquetFile::FromBytes(std::string(fuzz::Bytes(data, size)), "in");
    for (const auto& leaf : file.leaves()) {
      fuzz::AcceptWmError([&] {
        const parquet::Column c = file.Read(leaf.path);
        if (c.rows() != file.num_rows() ||
            static_cast<size_t>(c.row_starts.back()) != c.values.size()) {
          std::abort();
        }
      });
    }
  });
  return 0;
}

// Runs a fuzz target's LLVMFuzzerTestOneInput on files, without libFuzzer: ctest replays the seed
// corpora and the saved crash inputs (tests/fuzz/regressions) this way with any compiler.
//
//   fuzz_replay_<target> FILE_OR_DIR...   (a directory: every file in it, sorted by name)
//
// Exit codes: 0 every input passed; 1 an input let a non-wm::Error exception out (named on
// stderr); 2 bad arguments. A crash or sanitizer report ends the process as usual.
#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size);

namespace {
namespace fs = std::filesystem;

std::vector<fs::path> InputFiles(int argc, char** argv) {
  std::vector<fs::path> files;
  for (int i = 1; i < argc; ++i) {
    if (!fs::exists(argv[i])) {
      std::fprintf(stderr, "no such file or directory: %s\n", argv[i]);
      std::exit(2);
    }
    if (!fs::is_directory(argv[i])) {
      files.emplace_back(argv[i]);
      continue;
    }
    std::vector<fs::path> in_dir;
    for (const auto& e : fs::directory_iterator(argv[i])) {
      if (e.is_regular_file() && e.path().filename() != "README.md") in_dir.push_back(e.path());
    }
    std::sort(in_dir.begin(), in_dir.end());
    files.insert(files.end(), in_dir.begin(), in_dir.end());
  }
  return files;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s FILE_OR_DIR...\n", argv[0]);
    return 2;
  }
  int failed = 0;
  std::vector<fs::path> files = InputFiles(argc, argv);
  for (const fs::path& file : files) {
    std::ifstream in(file, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    try {
      LLVMFuzzerTestOneInput(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
    } catch (const std::exception& e) {
      std::fprintf(stderr, "FAIL %s: exception other than wm::Error: %s\n", file.c_str(), e.what());
      ++failed;
    }
  }
  std::printf("%zu inputs replayed, %d failed\n", files.size(), failed);
  return failed == 0 ? 0 : 1;
}

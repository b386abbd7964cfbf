#include "metrics/lpips/tools/npy_io.h"

#include <cstring>
#include <regex>

#include "core/atomic_file.h"
#include "core/error.h"

namespace wm::npy {
namespace {

constexpr char kMagic[] = "\x93NUMPY";

size_t ItemSize(const std::string& descr, const std::string& path) {
  if (descr == "|u1" || descr == "<u1") return 1;
  if (descr == "<f4") return 4;
  if (descr == "<f8") return 8;
  throw Error("unsupported .npy dtype '" + descr + "' (uint8, <f4, <f8 only)", {.file = path});
}

}  // namespace

int64_t Array::numel() const {
  int64_t n = 1;
  for (int64_t d : shape) n *= d;
  return n;
}

Array Read(const std::string& path) {
  const std::string file = ReadFile(path);
  Check(file.size() >= 10 && std::memcmp(file.data(), kMagic, 6) == 0, "not a .npy file",
        {.file = path});
  const int major = static_cast<unsigned char>(file[6]);
  size_t header_len = 0, pos = 0;
  if (major == 1) {
    header_len = static_cast<unsigned char>(file[8]) | static_cast<unsigned char>(file[9]) << 8;
    pos = 10;
  } else {
    Check(major <= 3 && file.size() >= 12, ".npy version not supported", {.file = path});
    for (int i = 3; i >= 0; --i)
      header_len = header_len << 8 | static_cast<unsigned char>(file[8 + i]);
    pos = 12;
  }
  Check(pos + header_len <= file.size(), ".npy header runs past the end", {.file = path});
  const std::string header = file.substr(pos, header_len);
  std::smatch m;
  Array a;
  Check(std::regex_search(header, m, std::regex(R"('descr':\s*'([^']+)')")), "no descr",
        {.file = path});
  a.descr = m[1];
  Check(std::regex_search(header, m, std::regex(R"('fortran_order':\s*(True|False))")) &&
            m[1] == "False",
        "Fortran-order arrays are not supported", {.file = path});
  Check(std::regex_search(header, m, std::regex(R"('shape':\s*\(([^)]*)\))")), "no shape",
        {.file = path});
  const std::string dims = m[1];
  const std::regex number(R"(\d+)");
  for (std::sregex_iterator it(dims.begin(), dims.end(), number), end; it != end; ++it) {
    a.shape.push_back(std::stoll(it->str()));
  }
  const size_t bytes = static_cast<size_t>(a.numel()) * ItemSize(a.descr, path);
  Check(file.size() - pos - header_len == bytes,
        "data size " + std::to_string(file.size() - pos - header_len) +
            " != " + std::to_string(bytes) + " expected from shape and dtype",
        {.file = path});
  a.bytes = file.substr(pos + header_len);
  return a;
}

void Write(const std::string& path, const std::string& descr, const std::vector<int64_t>& shape,
           const void* data, size_t bytes) {
  std::string dims;
  int64_t n = 1;
  for (size_t i = 0; i < shape.size(); ++i) {
    dims += (i ? ", " : "") + std::to_string(shape[i]);
    n *= shape[i];
  }
  if (shape.size() == 1) dims += ",";  // a Python 1-tuple
  Check(bytes == static_cast<size_t>(n) * ItemSize(descr, path), "size does not match shape",
        {.file = path});
  std::string header =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (" + dims + "), }";
  // Pad with spaces so that magic + 4 + header (ending in '\n') is a multiple of 64.
  header.resize(((10 + header.size() + 1 + 63) / 64) * 64 - 10 - 1, ' ');
  header += '\n';
  std::string out(kMagic, 6);
  out += '\x01';
  out += '\x00';
  out += static_cast<char>(header.size() & 0xff);
  out += static_cast<char>(header.size() >> 8);
  out += header;
  out.append(static_cast<const char*>(data), bytes);
  WriteFileAtomically(path, out);
}

}  // namespace wm::npy

// metrics_ref_tool: runs wm_metrics on .npy inputs so test_metrics_reference.py can compare it
// with scikit-image / SciPy without Python bindings.
//   metrics_ref_tool images A.npy B.npy [--data-range R] [--ssim-map OUT.npy] [--threads N]
//     -> {"mse", "psnr", "ssim", "ms_ssim"} (ms_ssim null below 176 pixels a side)
//   metrics_ref_tool frechet F1.npy F2.npy -> {"frechet": d}
// Arrays: C-order uint8 (R = 255), float32 or float64 (R = --data-range, default 1),
// shaped HxW or HxWxC for images and NxD for features.
#include <CLI/CLI.hpp>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <iostream>
#include <nlohmann/json.hpp>
#include <regex>
#include <string>
#include <vector>

#include "core/error.h"
#include "metrics/frechet.h"
#include "metrics/pixel_metrics.h"

namespace {

struct NpyArray {
  std::string descr;  // "<f8", "<f4" or "|u1"
  std::vector<int64_t> shape;
  std::string bytes;
};

// The .npy format (numpy.lib.format), versions 1-3: magic, header length, a Python dict header.
NpyArray ReadNpy(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  wm::Check(in.good(), "cannot open", {.file = path});
  std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  wm::Check(data.size() >= 10 && data.compare(0, 6, "\x93NUMPY") == 0, "not a .npy file",
            {.file = path});
  const int major = static_cast<uint8_t>(data[6]);
  const size_t len_bytes = major == 1 ? 2 : 4;
  uint32_t header_len = 0;
  std::memcpy(&header_len, data.data() + 8, len_bytes);  // little-endian host assumed
  const std::string header = data.substr(8 + len_bytes, header_len);
  std::smatch m;
  NpyArray a;
  wm::Check(std::regex_search(header, m, std::regex("'descr':\\s*'([^']+)'")), "no descr",
            {.file = path});
  a.descr = m[1];
  wm::Check(header.find("'fortran_order': False") != std::string::npos, "array is not C-order",
            {.file = path});
  wm::Check(std::regex_search(header, m, std::regex("'shape':\\s*\\(([^)]*)\\)")), "no shape",
            {.file = path});
  const std::string dims = m[1];
  const std::regex number("\\d+");
  for (std::sregex_iterator it(dims.begin(), dims.end(), number), end; it != end; ++it) {
    a.shape.push_back(std::stoll(it->str()));
  }
  a.bytes = data.substr(8 + len_bytes + header_len);
  return a;
}

void WriteNpy(const std::string& path, const wm::metrics::Image& image) {
  std::string header = "{'descr': '<f8', 'fortran_order': False, 'shape': (" +
                       std::to_string(image.height) + ", " + std::to_string(image.width) + ", " +
                       std::to_string(image.channels) + "), }";
  header.resize(((header.size() + 11 + 63) / 64) * 64 - 11, ' ');  // 64-byte aligned data
  header += '\n';
  std::ofstream out(path, std::ios::binary);
  const uint16_t len = static_cast<uint16_t>(header.size());
  out.write("\x93NUMPY\x01\x00", 8);
  out.write(reinterpret_cast<const char*>(&len), 2);
  out << header;
  out.write(reinterpret_cast<const char*>(image.pixels.data()),
            static_cast<std::streamsize>(image.pixels.size() * sizeof(double)));
}

std::vector<double> AsDoubles(const NpyArray& a, const std::string& path) {
  int64_t n = 1;
  for (int64_t d : a.shape) n *= d;
  std::vector<double> out(n);
  const char* p = a.bytes.data();
  if (a.descr == "|u1") {
    wm::Check(a.bytes.size() >= size_t(n), "truncated data", {.file = path});
    for (int64_t i = 0; i < n; ++i) out[i] = static_cast<uint8_t>(p[i]);
  } else if (a.descr == "<f4") {
    wm::Check(a.bytes.size() >= size_t(n) * 4, "truncated data", {.file = path});
    std::vector<float> f(n);
    std::memcpy(f.data(), p, n * 4);
    out.assign(f.begin(), f.end());
  } else if (a.descr == "<f8") {
    wm::Check(a.bytes.size() >= size_t(n) * 8, "truncated data", {.file = path});
    std::memcpy(out.data(), p, n * 8);
  } else {
    throw wm::Error("unsupported dtype " + a.descr, {.file = path});
  }
  return out;
}

wm::metrics::Image LoadNpyImage(const std::string& path, double float_range) {
  const NpyArray a = ReadNpy(path);
  wm::Check(a.shape.size() == 2 || a.shape.size() == 3, "expected HxW or HxWxC", {.file = path});
  const int channels = a.shape.size() == 3 ? static_cast<int>(a.shape[2]) : 1;
  const std::vector<double> values = AsDoubles(a, path);
  const double range = a.descr == "|u1" ? 255.0 : float_range;
  return wm::metrics::Image::FromDouble(values.data(), static_cast<int>(a.shape[0]),
                                        static_cast<int>(a.shape[1]), channels, range);
}

wm::metrics::FeatureSet LoadNpyFeatures(const std::string& path) {
  const NpyArray a = ReadNpy(path);
  wm::Check(a.shape.size() == 2, "expected N x D features", {.file = path});
  return {a.shape[0], a.shape[1], AsDoubles(a, path)};
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"metrics_ref_tool: wm_metrics on .npy arrays, JSON on stdout"};
  app.require_subcommand(1);
  std::string a_path, b_path, map_path;
  double range = 1.0;
  int threads = 1;
  auto* images = app.add_subcommand("images", "MSE, PSNR, SSIM, MS-SSIM of two images");
  images->add_option("a", a_path)->required();
  images->add_option("b", b_path)->required();
  images->add_option("--data-range", range, "R for float arrays");
  images->add_option("--ssim-map", map_path, "write the SSIM map here (.npy, float64 HxWxC)");
  images->add_option("--threads", threads);
  auto* frechet = app.add_subcommand("frechet", "Fréchet distance of two N x D feature sets");
  frechet->add_option("a", a_path)->required();
  frechet->add_option("b", b_path)->required();
  CLI11_PARSE(app, argc, argv);

  try {
    nlohmann::json out;
    if (*images) {
      const auto a = LoadNpyImage(a_path, range), b = LoadNpyImage(b_path, range);
      wm::metrics::Image map;
      out["mse"] = wm::metrics::JsonNumber(wm::metrics::Mse(a, b));
      out["psnr"] = wm::metrics::JsonNumber(wm::metrics::Psnr(a, b));
      out["ssim"] = wm::metrics::Ssim(a, b, map_path.empty() ? nullptr : &map, threads);
      const bool multiscale = std::min(a.height, a.width) >= wm::metrics::kMsSsimMinSide;
      out["ms_ssim"] = multiscale ? nlohmann::json(wm::metrics::MsSsim(a, b, threads)) : nullptr;
      if (!map_path.empty()) WriteNpy(map_path, map);
    } else {
      out["frechet"] =
          wm::metrics::FrechetDistance(LoadNpyFeatures(a_path), LoadNpyFeatures(b_path));
    }
    std::cout << out.dump() << "\n";
  } catch (const wm::Error& e) {
    std::cerr << "metrics_ref_tool: " << e.what() << "\n";
    return 1;
  }
  return 0;
}

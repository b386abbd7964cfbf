// tokenizer_ref_tool: runs a trained tokenizer checkpoint on given frames and writes what the
// PyTorch twin check (tests/tokenize/test_vqvae_twin.py) and bench/tokenizer_bench.py compare:
// codes, clamped reconstructions, encoder features, and optionally the loss terms and parameter
// gradients of one training-mode forward pass.
#include <torch/torch.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <iostream>
#include <nlohmann/json.hpp>

#include "core/atomic_file.h"
#include "core/error.h"
#include "core/log.h"
#include "core/provenance.h"
#include "core/tensor_archive.h"
#include "tokenize/tokenizer.h"
#include "tokenize/vqvae.h"
#include "trainkit/module_archive.h"

namespace {

constexpr const char* kFooter = R"(
Input: --frames FILE, raw little-endian float32 [n, 3, S, S] (planar RGB in [-1, 1], S = the
checkpoint's model.image_size, n = bytes / (12 S^2)).

With --out-dir DIR it writes NumPy .npy files (Tokenizer API, eval mode, no grad):
  DIR/codes.npy            uint32 [n, g, g]      Tokenizer::Encode
  DIR/reconstruction.npy   float32 [n, 3, S, S]  Tokenizer::Reconstruct (clamped to [-1, 1])
  DIR/features_K.npy       float32 [n, C, h, w]  Tokenizer::EncoderFeatures, K = 0 shallowest
--losses adds one forward pass of the VqVae module on all n frames as one batch (what a training
step computes) to the JSON, and --grads FILE writes the gradients of its loss with respect to
every parameter to a wmkit tensor archive as `grad/<parameter path>`.
--repeat R times R Tokenizer::Encode passes over all frames after one warm-up pass.

Prints one JSON object: {"frames", "image_size", "grid"; with --out-dir "features": [shapes];
with --losses "losses": {"loss", "recon_l1", "codebook_loss", "commitment", "perplexity",
"usage"}; with --repeat "encode_seconds", "encode_frames_per_second" and "encode_cpu_seconds"
(per pass; the last is process CPU time, all threads)}.

Example:
  tokenizer_ref_tool --checkpoint runs/tok-tiny --frames frames.f32 --out-dir /tmp/ref --losses

Exit codes: 0 success, 1 bad input or checkpoint (one line naming the file), CLI11's (>= 100)
for a bad command line.)";

struct Options {
  std::string checkpoint, frames_path, out_dir, grads_path, device = "cpu";
  int threads = 1, repeat = 0;
  bool losses = false;
};

// A version 1.0 .npy file: C order, little-endian `descr` ("<f4", "<u4").
void WriteNpy(const std::string& path, const std::string& descr, const std::vector<int64_t>& shape,
              const void* data, size_t bytes) {
  std::string dims;
  for (int64_t d : shape) dims += std::to_string(d) + ", ";
  if (shape.size() > 1) dims.resize(dims.size() - 1);
  std::string header =
      "{'descr': '" + descr + "', 'fortran_order': False, 'shape': (" + dims + "), }";
  header.append(63 - (10 + header.size()) % 64, ' ') += '\n';  // 10 + len is a multiple of 64
  const uint16_t len = static_cast<uint16_t>(header.size());
  std::string out = std::string("\x93NUMPY\x01\x00", 8);
  out += static_cast<char>(len & 0xff);
  out += static_cast<char>(len >> 8);
  out += header;
  out.append(static_cast<const char*>(data), bytes);
  wm::WriteFileAtomically(path, out);
}

std::vector<float> ReadFrames(const std::string& path, int size, int64_t& n) {
  const std::string bytes = wm::ReadFile(path);
  const size_t frame = 3ull * size * size * sizeof(float);
  wm::Check(!bytes.empty() && bytes.size() % frame == 0,
            std::to_string(bytes.size()) + " bytes is not a whole number of float32 [3, " +
                std::to_string(size) + ", " + std::to_string(size) + "] frames",
            {.file = path});
  n = static_cast<int64_t>(bytes.size() / frame);
  std::vector<float> frames(bytes.size() / sizeof(float));
  std::memcpy(frames.data(), bytes.data(), bytes.size());
  return frames;
}

// An anchored tokenizer's anchors here: frame i - 1 for frame i, blank (zeros) for frame 0
// (vqvae_twin.previous_frames). Empty for other tokenizers.
std::vector<float> PreviousFrames(const wm::tokenize::Tokenizer& tok,
                                  const std::vector<float>& frames) {
  if (!tok.anchored()) return {};
  const size_t floats = 3ull * tok.image_size() * tok.image_size();
  std::vector<float> anchors(floats, 0.f);
  anchors.insert(anchors.end(), frames.begin(), frames.end() - static_cast<long>(floats));
  return anchors;
}

void WriteOutputs(const wm::tokenize::Tokenizer& tok, const std::vector<float>& frames, int64_t n,
                  const std::string& dir, nlohmann::json& out) {
  std::filesystem::create_directories(dir);
  const int64_t g = tok.grid(), S = tok.image_size();
  const std::vector<uint32_t> codes = tok.Encode(frames.data(), n);
  const std::vector<int64_t> shape = tok.levels() == 1
                                         ? std::vector<int64_t>{n, g, g}
                                         : std::vector<int64_t>{n, tok.levels(), g, g};
  WriteNpy(dir + "/codes.npy", "<u4", shape, codes.data(), codes.size() * sizeof(uint32_t));
  const std::vector<float> anchors = PreviousFrames(tok, frames);
  const std::vector<float> recon =
      tok.Reconstruct(frames.data(), n, anchors.empty() ? nullptr : anchors.data());
  WriteNpy(dir + "/reconstruction.npy", "<f4", {n, 3, S, S}, recon.data(),
           recon.size() * sizeof(float));
  const auto features = tok.EncoderFeatures(frames.data(), n);
  out["features"] = nlohmann::json::array();
  for (size_t k = 0; k < features.size(); ++k) {
    WriteNpy(dir + "/features_" + std::to_string(k) + ".npy", "<f4", features[k].shape,
             features[k].values.data(), features[k].values.size() * sizeof(float));
    out["features"].push_back(features[k].shape);
  }
}

// The VqVae module itself (not the Tokenizer): one forward pass as in a training step, plus
// the gradients of its loss.
nlohmann::json Losses(const wm::tokenize::Tokenizer& tok, std::vector<float>& frames, int64_t n,
                      const Options& o) {
  wm::TensorArchiveReader reader(tok.checkpoint_path());
  wm::tokenize::VqVae model(tok.config().model);
  wm::trainkit::LoadModule(reader, "model/", *model);
  model->to(torch::Device(o.device));
  const int S = tok.image_size();
  torch::Tensor images = torch::from_blob(frames.data(), {n, 3, S, S}).to(torch::Device(o.device));
  std::vector<float> previous = PreviousFrames(tok, frames);
  torch::Tensor anchors;
  if (!previous.empty()) {
    anchors = torch::from_blob(previous.data(), {n, 3, S, S}).to(torch::Device(o.device));
  }
  wm::tokenize::VqVaeOutput v = model->forward(images, anchors);
  v.loss.backward();
  if (!o.grads_path.empty()) {
    wm::TensorArchiveWriter w;
    for (const auto& p : model->named_parameters()) {
      wm::trainkit::AddTensor(w, "grad/" + p.key(), p.value().grad());
    }
    w.SetMeta({{"loss", v.loss.item<double>()}, {"frames", n}});
    w.Write(o.grads_path);
  }
  return {{"loss", v.loss.item<double>()},
          {"recon_l1", v.recon_l1.item<double>()},
          {"codebook_loss", v.quant.codebook_loss.item<double>()},
          {"commitment", v.quant.commitment.item<double>()},
          {"perplexity", v.quant.perplexity},
          {"usage", v.quant.usage}};
}

int Run(Options& o) {
  wm::Check(o.threads > 0 && o.repeat >= 0, "--threads must be > 0 and --repeat >= 0");
  wm::Check(o.grads_path.empty() || o.losses, "--grads needs --losses");
  torch::set_num_threads(o.threads);
  const wm::tokenize::Tokenizer tok(o.checkpoint, o.device);
  int64_t n = 0;
  std::vector<float> frames = ReadFrames(o.frames_path, tok.image_size(), n);
  nlohmann::json out = {{"frames", n}, {"image_size", tok.image_size()}, {"grid", tok.grid()}};
  if (!o.out_dir.empty()) WriteOutputs(tok, frames, n, o.out_dir, out);
  if (o.losses) out["losses"] = Losses(tok, frames, n, o);
  if (o.repeat > 0) {
    tok.Encode(frames.data(), n);  // warm-up: allocator and oneDNN primitive caches
    const auto start = std::chrono::steady_clock::now();
    const std::clock_t cpu_start = std::clock();  // process CPU time, all threads
    for (int r = 0; r < o.repeat; ++r) tok.Encode(frames.data(), n);
    const double s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count() / o.repeat;
    out["encode_seconds"] = s;
    out["encode_frames_per_second"] = s > 0 ? n / s : 0.0;
    out["encode_cpu_seconds"] =
        static_cast<double>(std::clock() - cpu_start) / CLOCKS_PER_SEC / o.repeat;
  }
  std::cout << out.dump() << "\n";
  return 0;
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  CLI::App app{
      "tokenizer_ref_tool: a tokenizer checkpoint's codes, reconstructions, encoder "
      "features and losses on given frames"};
  app.footer(kFooter);
  app.set_version_flag("--version", wm::VersionString("tokenizer_ref_tool"));
  app.add_option("--checkpoint", o.checkpoint, "Run directory or checkpoint.wmt")->required();
  app.add_option("--frames", o.frames_path, "Raw float32 [n, 3, S, S] frames")->required();
  app.add_option("--out-dir", o.out_dir, "Write codes, reconstruction and features .npy here");
  app.add_flag("--losses", o.losses, "Print the loss terms of one forward pass");
  app.add_option("--grads", o.grads_path, "With --losses: write parameter gradients (.wmt)");
  app.add_option("--repeat", o.repeat, "Timed Encode passes after a warm-up (0: none)")
      ->capture_default_str();
  app.add_option("--threads", o.threads, "LibTorch intra-op threads")->capture_default_str();
  app.add_option("--device", o.device, "cpu, cuda or cuda:N")->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  wm::InitLogging("warn");
  try {
    return Run(o);
  } catch (const std::exception& e) {
    std::cerr << "tokenizer_ref_tool: error: " << e.what() << "\n";
    return 1;
  }
}

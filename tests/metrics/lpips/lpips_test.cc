#include "metrics/lpips/lpips.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <functional>
#include <map>
#include <random>

#include "core/error.h"
#include "core/tensor_archive.h"
#include "tests/core/test_util.h"

namespace wm::metrics {
namespace {

namespace fs = std::filesystem;
using ::testing::HasSubstr;

// Fixed random LPIPS weights (scripts/export_lpips_weights.py --random-seed 0), cached in the
// build tree and rewritten when the script is newer; the script writes atomically, so parallel
// test processes may race harmlessly.
std::string RandomWeights() {
  const std::string script = test::SourceDir() + "/scripts/export_lpips_weights.py";
  const std::string path = std::string(WM_LPIPS_TEST_DIR) + "/lpips-random-seed0.wmt";
  if (!fs::exists(path) || fs::last_write_time(path) < fs::last_write_time(script)) {
    const std::string cmd =
        "/usr/bin/python3 " + script + " --random-seed 0 --out " + path + " > /dev/null";
    if (std::system(cmd.c_str()) != 0) throw Error("failed: " + cmd);
  }
  return path;
}

using Image = std::vector<uint8_t>;

Image RandomImage(int h, int w, uint32_t seed) {
  std::mt19937 rng(seed);
  Image im(static_cast<size_t>(h) * w * 3);
  for (auto& v : im) v = static_cast<uint8_t>(rng() & 0xff);
  return im;
}

Image Gradient(int h, int w, int phase) {
  Image im(static_cast<size_t>(h) * w * 3);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      for (int c = 0; c < 3; ++c)
        im[(y * w + x) * 3 + c] = static_cast<uint8_t>((x * 4 + y * c + phase) % 256);
    }
  }
  return im;
}

std::vector<const uint8_t*> Ptrs(const std::vector<Image>& images) {
  std::vector<const uint8_t*> p;
  for (const Image& im : images) p.push_back(im.data());
  return p;
}

class LpipsTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { weights_ = new std::string(RandomWeights()); }
  static void TearDownTestSuite() { delete weights_; }
  static std::string* weights_;
};
std::string* LpipsTest::weights_ = nullptr;

TEST_F(LpipsTest, IdenticalImagesAreZero) {
  Lpips lpips(*weights_);
  std::vector<Image> a = {RandomImage(64, 64, 1), Gradient(64, 64, 0), Gradient(64, 64, 9)};
  for (double d : lpips.Distance(Ptrs(a), Ptrs(a), 64, 64)) EXPECT_EQ(d, 0.0);
}

TEST_F(LpipsTest, SymmetricAndPositive) {
  Lpips lpips(*weights_);
  std::vector<Image> a = {RandomImage(64, 64, 1), Gradient(64, 64, 0), Gradient(64, 64, 0)};
  std::vector<Image> b = {RandomImage(64, 64, 2), Gradient(64, 64, 5), RandomImage(64, 64, 3)};
  const std::vector<double> ab = lpips.Distance(Ptrs(a), Ptrs(b), 64, 64);
  const std::vector<double> ba = lpips.Distance(Ptrs(b), Ptrs(a), 64, 64);
  ASSERT_EQ(ab.size(), 3u);
  for (size_t i = 0; i < ab.size(); ++i) {
    EXPECT_GT(ab[i], 1e-4) << i;
    EXPECT_NEAR(ab[i], ba[i], 1e-6 * ab[i]) << i;
  }
  EXPECT_LT(ab[1], ab[2]);  // a shifted gradient is closer than noise
}

// Batch size, repeated calls, uint8 vs float input and the per-layer split agree at h x w.
void ExpectBatchingAndInputTypeDoNotChangeResults(const std::string& weights, int h, int w) {
  std::vector<Image> a, b;
  for (uint32_t i = 0; i < 5; ++i) {
    a.push_back(RandomImage(h, w, i));
    b.push_back(Gradient(h, w, static_cast<int>(i)));
  }
  Lpips batched(weights, LpipsOptions{.batch_size = 16});
  Lpips single(weights, LpipsOptions{.batch_size = 2});
  const std::vector<double> d16 = batched.Distance(Ptrs(a), Ptrs(b), h, w);
  const std::vector<double> d2 = single.Distance(Ptrs(a), Ptrs(b), h, w);
  EXPECT_EQ(batched.Distance(Ptrs(a), Ptrs(b), h, w), d16);  // deterministic
  std::vector<std::vector<float>> fa, fb;
  for (size_t i = 0; i < a.size(); ++i) {
    fa.emplace_back(a[i].begin(), a[i].end());
    fb.emplace_back(b[i].begin(), b[i].end());
    for (float& v : fa.back()) v = v / 127.5f - 1.0f;
    for (float& v : fb.back()) v = v / 127.5f - 1.0f;
  }
  std::vector<const float*> pa, pb;
  for (size_t i = 0; i < a.size(); ++i) pa.push_back(fa[i].data()), pb.push_back(fb[i].data());
  const std::vector<double> df = batched.DistanceFloat(pa, pb, h, w);
  const auto layers = batched.LayerDistances(Ptrs(a), Ptrs(b), h, w);
  for (size_t i = 0; i < a.size(); ++i) {
    EXPECT_NEAR(d16[i], d2[i], 1e-6 * d16[i]) << i;
    EXPECT_NEAR(d16[i], df[i], 1e-6 * d16[i]) << i;
    double sum = 0;
    for (double t : layers[i]) sum += t;
    EXPECT_NEAR(sum, d16[i], 1e-9) << i;
  }
  EXPECT_TRUE(batched.Distance({}, {}, h, w).empty());
}

TEST_F(LpipsTest, BatchingThreadsAndInputTypeDoNotChangeResults) {
  ExpectBatchingAndInputTypeDoNotChangeResults(*weights_, 48, 40);
  // Above 128 x 128 pixels the trunk runs channels-last (AlexNetTrunkImpl::kBlockedMaxPixels).
  ExpectBatchingAndInputTypeDoNotChangeResults(*weights_, 144, 176);
}

TEST_F(LpipsTest, FeatureShapesFollowAlexNet) {
  Lpips lpips(*weights_);
  const Image im = RandomImage(64, 64, 4);
  const std::vector<LpipsFeatureMap> maps = lpips.Features(im.data(), 64, 64);
  ASSERT_EQ(maps.size(), 5u);
  const std::array<std::array<int64_t, 3>, 5> expected = {
      {{64, 15, 15}, {192, 7, 7}, {384, 3, 3}, {256, 3, 3}, {256, 3, 3}}};
  for (int l = 0; l < 5; ++l) {
    EXPECT_EQ(maps[l].shape, expected[l]) << "relu" << l + 1;
    for (float v : maps[l].data) ASSERT_GE(v, 0.0f);  // ReLU outputs
  }
}

TEST_F(LpipsTest, RejectsBadCalls) {
  Lpips lpips(*weights_);
  const Image a = RandomImage(30, 64, 1);
  EXPECT_THROW(lpips.Distance({a.data()}, {a.data()}, 30, 64), Error);  // relu5 would be empty
  EXPECT_THROW(lpips.Distance({a.data()}, {}, 64, 30), Error);
  EXPECT_THROW(Lpips(*weights_, LpipsOptions{.batch_size = 0}), Error);
  EXPECT_THROW(Lpips(*weights_, "tpu:7"), Error);
}

using Values = std::map<std::string, std::vector<float>>;
using Shapes = std::map<std::string, std::vector<int64_t>>;

// Copies the test weights into a new archive with `edit` applied to the tensor map.
std::string EditedWeights(const std::string& weights, const test::TempDir& dir,
                          const std::function<void(Values&, Shapes&)>& edit) {
  TensorArchiveReader in(weights);
  Values values;
  Shapes shapes;
  for (const std::string& name : in.Names()) {
    const ArchiveTensor& t = in.Get(name);
    const float* p = reinterpret_cast<const float*>(t.data);
    values[name].assign(p, p + t.numel());
    shapes[name] = t.shape;
  }
  edit(values, shapes);
  TensorArchiveWriter out;
  for (const auto& [name, v] : values) out.AddFloat32(name, shapes[name], v.data());
  out.SetMeta(in.meta());
  const std::string path = dir / "edited.wmt";
  out.Write(path);
  return path;
}

TEST_F(LpipsTest, WeightErrorsNameFileAndTensor) {
  test::TempDir dir;
  auto expect_error = [&](const std::string& path, const std::string& what,
                          const std::string& tensor) {
    try {
      Lpips lpips(path);
      ADD_FAILURE() << "no error for " << tensor;
    } catch (const Error& e) {
      EXPECT_THAT(e.what(), HasSubstr(what));
      EXPECT_THAT(e.what(), HasSubstr(tensor));
      EXPECT_THAT(e.what(), HasSubstr(path));
    }
  };
  expect_error(
      EditedWeights(*weights_, dir, [](Values& v, Shapes&) { v.erase("lin3.model.1.weight"); }),
      "missing tensor", "lin3.model.1.weight");
  expect_error(EditedWeights(*weights_, dir,
                             [](Values&, Shapes& s) {
                               s["net.slice2.3.weight"] = {64, 192, 5, 5};  // transposed
                             }),
               "expected [192, 64, 5, 5]", "net.slice2.3.weight");
  expect_error(EditedWeights(*weights_, dir,
                             [](Values& v, Shapes&) { v["lin0.model.1.weight"][3] = -0.5f; }),
               "negative lin weight", "lin0.model.1.weight");
  expect_error(dir / "absent.wmt", "cannot open", "absent.wmt");
}

}  // namespace
}  // namespace wm::metrics

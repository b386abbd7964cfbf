#include "core/tensor_archive.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>

#include "core/error.h"
#include "core/mapped_file.h"
#include "tests/core/test_util.h"

namespace wm {
namespace {

using ::testing::HasSubstr;

// Writes a small archive: two float32 tensors, one uint8, one int64 scalar-ish, and meta.
void WriteSample(const std::string& path) {
  TensorArchiveWriter w;
  std::vector<float> conv(2 * 3 * 3 * 3);
  for (size_t i = 0; i < conv.size(); ++i) conv[i] = 0.25f * static_cast<float>(i) - 3.0f;
  w.AddFloat32("net.slice1.0.weight", {2, 3, 3, 3}, conv.data());
  const float bias[2] = {1.5f, -2.0f};
  w.AddFloat32("net.slice1.0.bias", {2}, bias);
  const uint8_t bytes[5] = {1, 2, 3, 4, 255};
  w.Add("mask", DType::kUInt8, {5}, bytes, sizeof(bytes));
  const int64_t step = 123456789012345;
  w.Add("step", DType::kInt64, {}, &step, sizeof(step));
  w.SetMeta({{"model", "test"}, {"seed", 7}});
  w.Write(path);
}

// Offset in the file of tensor `name`'s first data byte (found by content: it is unique here).
uint64_t DataOffset(const std::string& path, const std::string& name) {
  TensorArchiveReader r(path);
  const ArchiveTensor& t = r.Get(name);
  const size_t at = MappedFile(path).view().find(
      std::string_view(reinterpret_cast<const char*>(t.data), t.length));
  EXPECT_NE(at, std::string_view::npos);
  return at;
}

TEST(TensorArchiveTest, RoundTrip) {
  test::TempDir dir;
  const std::string path = dir / "a.wmt";
  WriteSample(path);
  TensorArchiveReader r(path);
  EXPECT_EQ(r.Names(),
            (std::vector<std::string>{"mask", "net.slice1.0.bias", "net.slice1.0.weight", "step"}));
  std::span<const float> conv = r.Float32("net.slice1.0.weight", {2, 3, 3, 3});
  ASSERT_EQ(conv.size(), 54u);
  for (size_t i = 0; i < conv.size(); ++i) EXPECT_EQ(conv[i], 0.25f * i - 3.0f);
  EXPECT_EQ(r.Float32("net.slice1.0.bias", {2})[1], -2.0f);
  const ArchiveTensor& mask = r.Get("mask");
  EXPECT_EQ(mask.dtype, DType::kUInt8);
  EXPECT_EQ(mask.data[4], 255);
  const ArchiveTensor& step = r.Get("step");
  EXPECT_TRUE(step.shape.empty());
  EXPECT_EQ(step.numel(), 1);
  EXPECT_EQ(*reinterpret_cast<const int64_t*>(step.data), 123456789012345);
  EXPECT_EQ(r.meta()["seed"], 7);
  for (const std::string& name : r.Names()) {  // in-place use needs aligned data
    EXPECT_EQ(reinterpret_cast<uintptr_t>(r.Get(name).data) % kTensorArchiveAlignment, 0u);
  }
}

TEST(TensorArchiveTest, SameTensorsSameBytes) {
  test::TempDir dir;
  WriteSample(dir / "a.wmt");
  WriteSample(dir / "b.wmt");
  EXPECT_EQ(MappedFile(dir / "a.wmt").view(), MappedFile(dir / "b.wmt").view());
}

TEST(TensorArchiveTest, CorruptionNamesTheTensor) {
  test::TempDir dir;
  const std::string path = dir / "a.wmt";
  WriteSample(path);
  const uint64_t offset = DataOffset(path, "net.slice1.0.bias");
  test::FlipByte(path, offset + 5);
  try {
    TensorArchiveReader r(path);
    FAIL() << "corruption not detected";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("CRC32C mismatch"));
    EXPECT_THAT(e.what(), HasSubstr("net.slice1.0.bias"));
    EXPECT_THAT(e.what(), HasSubstr(path));
  }
}

TEST(TensorArchiveTest, MissingTensorAndWrongShape) {
  test::TempDir dir;
  const std::string path = dir / "a.wmt";
  WriteSample(path);
  TensorArchiveReader r(path);
  EXPECT_FALSE(r.Contains("lin0.model.1.weight"));
  try {
    r.Get("lin0.model.1.weight");
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("missing tensor"));
    EXPECT_THAT(e.what(), HasSubstr("lin0.model.1.weight"));
    EXPECT_EQ(e.context().file, path);
  }
  try {
    r.Float32("net.slice1.0.weight", {2, 3, 5, 5});
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("shape is [2, 3, 3, 3], expected [2, 3, 5, 5]"));
  }
  EXPECT_THROW(r.Float32("mask", {5}), Error);  // uint8, not float32
}

TEST(TensorArchiveTest, RejectsBadFiles) {
  test::TempDir dir;
  const std::string path = dir / "a.wmt";
  EXPECT_THROW(TensorArchiveReader(dir / "absent.wmt"), Error);
  WriteSample(path);
  const uint64_t size = MappedFile(path).size();
  test::Truncate(path, size - 1);
  try {
    TensorArchiveReader r(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("truncated"));
  }
  WriteSample(path);
  test::FlipByte(path, 0);
  try {
    TensorArchiveReader r(path);
    FAIL();
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("magic"));
  }
  WriteSample(path);
  test::FlipByte(path, 17);  // inside the JSON header
  EXPECT_THROW(TensorArchiveReader{path}, Error);
}

TEST(TensorArchiveTest, WriterRejectsInconsistentInput) {
  TensorArchiveWriter w;
  const float v[4] = {};
  EXPECT_THROW(w.Add("x", DType::kFloat32, {3}, v, sizeof(v)), Error);
  w.AddFloat32("x", {4}, v);
  EXPECT_THROW(w.AddFloat32("x", {4}, v), Error);
}

// The numpy reader of scripts/export_lpips_weights.py (written from the doc) reads C++ output.
TEST(TensorArchiveTest, NumpyReadsCppArchive) {
  test::TempDir dir;
  const std::string path = dir / "a.wmt";
  WriteSample(path);
  const std::string out = dir / "list.txt";
  // WM_PYTHON: the build's Python of the reference checks (a GPU image's /usr/bin/python3 has
  // no numpy).
  const char* python = std::getenv("WM_PYTHON");
  const std::string cmd = std::string(python != nullptr ? python : "/usr/bin/python3") + " " +
                          test::SourceDir() + "/scripts/export_lpips_weights.py --list " + path +
                          " > " + out;
  ASSERT_EQ(std::system(cmd.c_str()), 0) << cmd;
  std::ifstream in(out);
  const std::string listing((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_THAT(listing, HasSubstr("net.slice1.0.weight\tfloat32\t[2, 3, 3, 3]"));
  EXPECT_THAT(listing, HasSubstr("step\tint64\t[]"));
  EXPECT_THAT(listing, HasSubstr("\"seed\": 7"));
}

}  // namespace
}  // namespace wm

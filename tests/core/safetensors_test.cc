// core/safetensors.h: the writer's bytes read back exactly, and every way a file can break the
// spec is one error naming the file (and the tensor). The checkpoint conversion
// (core/checkpoint_safetensors.h) round-trips a WMTENSR1 archive byte for byte.
#include "core/safetensors.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cstring>

#include "core/atomic_file.h"
#include "core/checkpoint_safetensors.h"
#include "core/tensor_archive.h"
#include "tests/core/test_util.h"

namespace wm {
namespace {

using ::testing::HasSubstr;

// A file of `header` JSON (not padded) and `buffer` bytes, as a hand-made fixture.
std::string FileWith(const std::string& header, const std::string& buffer) {
  std::string out(8, '\0');
  const uint64_t n = header.size();
  for (int i = 0; i < 8; ++i) out[i] = static_cast<char>((n >> (8 * i)) & 0xff);
  return out + header + buffer;
}

std::string ParseError(const std::string& file) {
  return test::ErrorText([&] { ParseSafetensors(file, "bad.safetensors"); });
}

TEST(Safetensors, RoundTripKeepsBytesAndAlignsEachTensor) {
  test::TempDir dir;
  const std::vector<float> f32 = {1.5f, -2.0f, 3.25f};
  const std::vector<int64_t> i64 = {7, -8};
  const std::vector<uint8_t> u8 = {1, 2, 3, 4, 5};
  const std::vector<double> f64 = {0.125};  // a scalar
  auto view = [](const auto& v) {
    return std::string_view(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0]));
  };
  const std::vector<SafetensorsTensor> tensors = {{"bytes", DType::kUInt8, {5}, view(u8)},
                                                  {"w.weight", DType::kFloat32, {1, 3}, view(f32)},
                                                  {"steps", DType::kInt64, {2}, view(i64)},
                                                  {"scale", DType::kFloat64, {}, view(f64)},
                                                  {"empty", DType::kFloat32, {0, 4}, {}}};
  const std::map<std::string, std::string> metadata = {{"format", "pt"}, {"note", "ü"}};
  WriteSafetensors(dir / "a.safetensors", tensors, metadata);
  WriteSafetensors(dir / "b.safetensors", tensors, metadata);
  const std::string bytes = ReadFile(dir / "a.safetensors");
  EXPECT_EQ(bytes, ReadFile(dir / "b.safetensors")) << "same input, same bytes";

  const SafetensorsReader reader(dir / "a.safetensors");
  EXPECT_EQ(reader.contents().metadata, metadata);
  ASSERT_EQ(reader.contents().tensors.size(), tensors.size());
  for (const SafetensorsTensor& want : tensors) {
    const SafetensorsTensor& got = reader.contents().tensors.at(want.name);
    EXPECT_EQ(got.dtype, want.dtype) << want.name;
    EXPECT_EQ(got.shape, want.shape) << want.name;
    EXPECT_EQ(got.bytes, want.bytes) << want.name;
    const auto address = reinterpret_cast<uintptr_t>(got.bytes.data());
    EXPECT_EQ(address % DTypeSize(got.dtype), 0u) << want.name << " is not item-aligned";
  }
  uint64_t header_length = 0;
  std::memcpy(&header_length, bytes.data(), 8);
  EXPECT_EQ(header_length % kSafetensorsHeaderAlignment, 0u);
}

TEST(Safetensors, AcceptsAHandWrittenFileWithoutMetadata) {
  const std::string file = FileWith(R"({"b":{"dtype":"U8","shape":[2],"data_offsets":[4,6]},)"
                                    R"("a":{"dtype":"I32","shape":[1],"data_offsets":[0,4]}}   )",
                                    std::string("\x01\x00\x00\x00\x07\x08", 6));
  const SafetensorsContents c = ParseSafetensors(file, "ok.safetensors");
  EXPECT_TRUE(c.metadata.empty());
  EXPECT_EQ(c.tensors.at("a").bytes, std::string_view("\x01\x00\x00\x00", 4));
  EXPECT_EQ(c.tensors.at("b").bytes, "\x07\x08");
}

TEST(Safetensors, EveryDefectIsOneErrorNamingFileAndTensor) {
  const std::string t = R"("t":{"dtype":"F32","shape":[2],"data_offsets":)";
  const std::string eight(8, '\0');
  struct Case {
    std::string file, expected;
  };
  const std::vector<Case> cases = {
      {"abc", "bad.safetensors: truncated: 3 bytes, expected an 8-byte header length"},
      {FileWith("{}", "").substr(0, 9), "truncated header: length field says 2 bytes"},
      {FileWith("[1]", ""), "header is not a JSON object"},
      {FileWith("{\"t\":", ""), "bad header JSON"},
      {FileWith("{" + t + "[0,8]}}", "1234567"), "lie outside the byte buffer of 7 bytes"},
      {FileWith("{" + t + "[8,0]}}", eight), "end before they begin"},
      {FileWith("{" + t + "[0,4]}}", "1234"), "shape [2] of F32 needs 8 bytes"},
      {FileWith(R"({"t":{"dtype":"BF16","shape":[2],"data_offsets":[0,4]}})", "1234"),
       "key 't': dtype 'BF16' is not one wmkit holds"},
      {FileWith(R"({"t":{"dtype":"Q9","shape":[],"data_offsets":[0,1]}})", "1"), "dtype 'Q9'"},
      {FileWith(R"({"t":{"dtype":"U8","shape":[-1],"data_offsets":[0,0]}})", ""),
       "negative dimension"},
      {FileWith(R"({"t":{"dtype":"U8","shape":[4611686018427387904,8],"data_offsets":[0,0]}})", ""),
       "overflows 64-bit sizes"},
      {FileWith(R"({"t":{"dtype":"U8","shape":[1]}})", "1"), "lacks field 'data_offsets'"},
      {FileWith("{" + t + "[0,8]},\"u\":{\"dtype\":\"U8\",\"shape\":[4],\"data_offsets\":[4,8]}}",
                eight),
       "key 'u': data_offsets [4, 8] overlap the previous tensor, which ends at 8"},
      {FileWith("{" + t + "[4,12]}}", eight + "1234"),
       "leave a hole: the previous tensor ends at 0"},
      {FileWith("{" + t + "[0,8]}}", eight + "x"), "has 9 bytes but the tensors cover only 8"},
      {FileWith("{" + t + "[0,8]}," + t + "[0,8]}}", eight), "duplicate header key 't'"},
      {FileWith(R"({"__metadata__":{"n":1}})", ""), "__metadata__ value of 'n' is not a string"},
  };
  for (const Case& c : cases) {
    const std::string message = ParseError(c.file);
    EXPECT_THAT(message, HasSubstr(c.expected));
    EXPECT_THAT(message, HasSubstr("bad.safetensors")) << message;
  }
}

TEST(Safetensors, WriterRefusesInconsistentTensors) {
  test::TempDir dir;
  const float x = 1;
  const std::string_view four(reinterpret_cast<const char*>(&x), 4);
  EXPECT_THAT(test::ErrorText([&] {
                WriteSafetensors(dir / "w.safetensors", {{"t", DType::kFloat32, {2}, four}}, {});
              }),
              HasSubstr("key 't': bytes do not match shape [2]"));
  EXPECT_THAT(test::ErrorText([&] {
                WriteSafetensors(
                    dir / "w.safetensors",
                    {{"t", DType::kFloat32, {1}, four}, {"t", DType::kFloat32, {1}, four}}, {});
              }),
              HasSubstr("duplicate tensor name"));
  EXPECT_FALSE(std::filesystem::exists(dir / "w.safetensors"));
}

// A checkpoint-like archive: model tensors of two dtypes, optimizer state and a meta object.
void WriteCheckpoint(const std::string& path, float bias) {
  TensorArchiveWriter w;
  const std::vector<float> weight = {1, 2, 3, 4, 5, 6};
  const std::vector<int64_t> count = {42};
  w.AddFloat32("model/layer.weight", {2, 3}, weight.data());
  w.AddFloat32("model/layer.bias", {1}, &bias);
  w.Add("model/steps", DType::kInt64, {1}, count.data(), 8);
  w.AddFloat32("adamw/exp_avg/layer.bias", {1}, &bias);
  w.SetMeta({{"config", {{"model", {{"d_model", 3}}}}}, {"step", 7}});
  w.Write(path);
}

TEST(CheckpointSafetensors, ExportsModelTensorsAndImportsThemBack) {
  test::TempDir dir;
  WriteCheckpoint(dir / "ckpt.wmt", 0.5f);
  WriteCheckpoint(dir / "other.wmt", -1.0f);
  EXPECT_EQ(ExportCheckpointSafetensors({dir / "ckpt.wmt", dir / "m.safetensors"}), 3u);
  const SafetensorsReader file(dir / "m.safetensors");
  std::vector<std::string> names;
  for (const auto& [name, t] : file.contents().tensors) names.push_back(name);
  EXPECT_EQ(names, (std::vector<std::string>{"layer.bias", "layer.weight", "steps"}));
  EXPECT_EQ(nlohmann::json::parse(file.contents().metadata.at("wmkit")),
            TensorArchiveReader(dir / "ckpt.wmt").meta());
  EXPECT_EQ(file.contents().metadata.at("wmkit_tensors"), "model");

  // other.wmt's layout and optimizer state with ckpt.wmt's weights: ckpt.wmt but for adamw/.
  EXPECT_EQ(ImportCheckpointSafetensors({dir / "m.safetensors", dir / "other.wmt", dir / "n.wmt"}),
            3u);
  EXPECT_EQ(test::ChangedTensors(dir / "ckpt.wmt", dir / "n.wmt", "model/"),
            std::vector<std::string>{});
  EXPECT_EQ(test::ChangedTensors(dir / "other.wmt", dir / "n.wmt", "adamw/"),
            std::vector<std::string>{});
  ImportCheckpointSafetensors({dir / "m.safetensors", dir / "ckpt.wmt", dir / "same.wmt"});
  EXPECT_EQ(ReadFile(dir / "same.wmt"), ReadFile(dir / "ckpt.wmt"));

  ExportCheckpointSafetensors({dir / "ckpt.wmt", dir / "all.safetensors", true});
  EXPECT_THAT(test::ErrorText([&] {
                ImportCheckpointSafetensors({dir / "all.safetensors", dir / "ckpt.wmt", dir / "x"});
              }),
              HasSubstr("written by `export --all`: import it with --all"));
  ImportCheckpointSafetensors({dir / "all.safetensors", dir / "ckpt.wmt", dir / "all.wmt", true});
  EXPECT_EQ(ReadFile(dir / "all.wmt"), ReadFile(dir / "ckpt.wmt"));
}

TEST(CheckpointSafetensors, ImportNamesTheFirstMismatch) {
  test::TempDir dir;
  WriteCheckpoint(dir / "ckpt.wmt", 0.5f);
  const std::vector<float> six(6, 0.0f);
  const std::vector<int64_t> one = {1};
  auto bytes = [](const auto& v) {
    return std::string_view(reinterpret_cast<const char*>(v.data()), v.size() * sizeof(v[0]));
  };
  const SafetensorsTensor weight{"layer.weight", DType::kFloat32, {2, 3}, bytes(six)};
  const SafetensorsTensor bias{"layer.bias", DType::kFloat32, {1}, bytes(six).substr(0, 4)};
  const SafetensorsTensor steps{"steps", DType::kInt64, {1}, bytes(one)};
  struct Case {
    std::vector<SafetensorsTensor> tensors;
    std::string expected;
  };
  const std::vector<Case> cases = {
      {{weight, steps}, "key 'layer.bias': missing tensor ("},
      {{weight, bias, {"steps", DType::kFloat64, {1}, bytes(one)}},
       "key 'steps': dtype F64, expected I64"},
      {{{"layer.weight", DType::kFloat32, {3, 2}, bytes(six)}, bias, steps},
       "key 'layer.weight': shape [3, 2], expected [2, 3]"},
      {{weight, bias, steps, {"extra", DType::kInt64, {1}, bytes(one)}},
       "key 'extra': tensor is not in"},
  };
  for (const Case& c : cases) {
    WriteSafetensors(dir / "in.safetensors", c.tensors, {});
    EXPECT_THAT(
        test::ErrorText([&] {
          ImportCheckpointSafetensors({dir / "in.safetensors", dir / "ckpt.wmt", dir / "out.wmt"});
        }),
        HasSubstr(c.expected));
    EXPECT_FALSE(std::filesystem::exists(dir / "out.wmt"));
  }
}

}  // namespace
}  // namespace wm

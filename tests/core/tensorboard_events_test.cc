// core/tensorboard_events.h and core/tfrecord_frame.h against bytes worked out by hand from the
// protobuf wire format and event.proto / summary.proto field numbers (docs/tensorboard.md).
#include "core/tensorboard_events.h"

#include <gtest/gtest.h>

#include "core/crc32c.h"
#include "core/error.h"
#include "core/tfrecord_frame.h"

namespace wm {
namespace {

std::string Bytes(std::initializer_list<int> bytes) {
  std::string out;
  for (int b : bytes) out.push_back(static_cast<char>(b));
  return out;
}

TEST(TensorBoardEvents, ScalarEventHasTheProtobufBytes) {
  const std::string wall_time_1 = Bytes({0x09, 0, 0, 0, 0, 0, 0, 0xf0, 0x3f});  // field 1, 1.0
  const std::string value = Bytes({0x0a, 3}) + "a/b" + Bytes({0x15, 0, 0, 0, 0x3f});  // tag, 0.5f
  const std::string summary = Bytes({0x0a, static_cast<int>(value.size())}) + value;
  EXPECT_EQ(EncodeScalarsEvent(1.0, 300, {{"a/b", 0.5f}}),
            wall_time_1 + Bytes({0x10, 0xac, 0x02}) +  // step 300 as a varint
                Bytes({0x2a, static_cast<int>(summary.size())}) + summary);
  EXPECT_EQ(EncodeScalarsEvent(1.0, -1, {}),  // int64 -1: ten varint bytes; empty summary
            wall_time_1 +
                Bytes({0x10, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0xff, 0x01}) +
                Bytes({0x2a, 0}));
  EXPECT_EQ(EncodeFileVersionEvent(1.0), wall_time_1 + Bytes({0x1a, 13}) + "brain.Event:2");
}

TEST(TensorBoardEvents, ImageEventHasTheProtobufBytes) {
  const std::string wall_time_1 = Bytes({0x09, 0, 0, 0, 0, 0, 0, 0xf0, 0x3f});
  // Summary.Image: height 2, width 300 (varint ac 02), colorspace 3, encoded_image_string "PNG".
  const std::string image = Bytes({0x08, 2, 0x10, 0xac, 0x02, 0x18, 3, 0x22, 3}) + "PNG";
  const std::string value = Bytes({0x0a, 3}) + "v/r" +  // tag, then image (field 4)
                            Bytes({0x22, static_cast<int>(image.size())}) + image;
  const std::string summary = Bytes({0x0a, static_cast<int>(value.size())}) + value;
  EXPECT_EQ(
      EncodeImageEvent(1.0, 7, {"v/r", 2, 300, 3, "PNG"}),
      wall_time_1 + Bytes({0x10, 7}) + Bytes({0x2a, static_cast<int>(summary.size())}) + summary);
}

TEST(TensorBoardEvents, DecodeEventStepReadsTheStepOfEveryKind) {
  EXPECT_EQ(DecodeEventStep(EncodeScalarsEvent(5.0, 300, {{"a/b", 0.5f}})), 300);
  EXPECT_EQ(DecodeEventStep(EncodeScalarsEvent(5.0, -1, {})), -1);
  EXPECT_EQ(DecodeEventStep(EncodeImageEvent(5.0, 1200, {"v/r", 1, 1, 3, "x"})), 1200);
  EXPECT_EQ(DecodeEventStep(EncodeFileVersionEvent(5.0)), 0);  // no step field: protobuf's 0
  const std::string event = EncodeScalarsEvent(5.0, 300, {{"a/b", 0.5f}});
  EXPECT_THROW(DecodeEventStep(event.substr(0, event.size() - 2)), Error);  // summary cut short
}

TEST(TensorBoardEvents, UnframeTfRecordsStopsAtACutOrDamagedRecord) {
  const std::string two = FrameTfRecord("first") + FrameTfRecord("second record");
  EXPECT_EQ(UnframeTfRecords(two), (std::vector<std::string_view>{"first", "second record"}));
  EXPECT_EQ(UnframeTfRecords(two.substr(0, two.size() - 1)),  // a kill mid-append
            std::vector<std::string_view>{"first"});
  std::string damaged = two;
  damaged[damaged.size() - 6] ^= 1;  // a byte of "second record"
  EXPECT_EQ(UnframeTfRecords(damaged), std::vector<std::string_view>{"first"});
  EXPECT_TRUE(UnframeTfRecords("").empty());
}

TEST(TensorBoardEvents, TfRecordFrameHasLengthAndMaskedCrcs) {
  const std::string framed = FrameTfRecord("abc");
  ASSERT_EQ(framed.size(), 8u + 4 + 3 + 4);
  EXPECT_EQ(framed.substr(0, 8), Bytes({3, 0, 0, 0, 0, 0, 0, 0}));
  auto u32_at = [&](size_t pos) {
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) v = (v << 8) | static_cast<uint8_t>(framed[pos + i]);
    return v;
  };
  EXPECT_EQ(UnmaskCrc(u32_at(8)), Crc32c(framed.substr(0, 8)));
  EXPECT_EQ(framed.substr(12, 3), "abc");
  EXPECT_EQ(UnmaskCrc(u32_at(15)), Crc32c("abc"));
}

}  // namespace
}  // namespace wm

#include "core/crc32c.h"

#include <gtest/gtest.h>

#include <string>

namespace wm {
namespace {

// Check values from RFC 3720 (iSCSI), appendix B.4, and the CRC catalogue's "123456789".
TEST(Crc32c, KnownVectors) {
  EXPECT_EQ(Crc32c("123456789"), 0xE3069283u);
  EXPECT_EQ(Crc32c(std::string(32, '\0')), 0x8A9136AAu);
  EXPECT_EQ(Crc32c(std::string(32, '\xFF')), 0x62A8AB43u);
  std::string ascending, descending;
  for (int i = 0; i < 32; ++i) {
    ascending.push_back(static_cast<char>(i));
    descending.push_back(static_cast<char>(31 - i));
  }
  EXPECT_EQ(Crc32c(ascending), 0x46DD794Eu);
  EXPECT_EQ(Crc32c(descending), 0x113FDB5Cu);
  EXPECT_EQ(Crc32c(""), 0u);
}

TEST(Crc32c, IncrementalEqualsWhole) {
  std::string data;
  for (int i = 0; i < 1000; ++i) data.push_back(static_cast<char>(i * 7));
  for (size_t split : {0, 1, 7, 8, 9, 500, 999}) {
    EXPECT_EQ(Crc32c(data.substr(split), Crc32c(data.substr(0, split))), Crc32c(data)) << split;
  }
}

TEST(Crc32c, MaskRoundTripsAndMatchesTensorFlow) {
  for (uint32_t c : {0u, 1u, 0xE3069283u, 0xFFFFFFFFu}) EXPECT_EQ(UnmaskCrc(MaskCrc(c)), c);
  // python3-crc32c gives 0x8C28B28A for 8 zero bytes; the mask is rot-right-15 + 0xa282ead8.
  EXPECT_EQ(Crc32c(std::string(8, '\0')), 0x8C28B28Au);
  EXPECT_EQ(MaskCrc(0x8C28B28Au), ((0x8C28B28Au >> 15) | (0x8C28B28Au << 17)) + 0xa282ead8u);
}

}  // namespace
}  // namespace wm

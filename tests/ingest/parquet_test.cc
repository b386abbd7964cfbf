// The Parquet reader (ingest/parquet) on hand-made files from tests/ingest/parquet_writer.h:
// the encodings the LeRobot sample does not exercise (dictionary pages, data pages v2, optional
// scalars, null and empty lists, rows spanning pages and row groups) and damaged bytes. The real
// sample's values are checked in lerobot_test.cc.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "core/error.h"
#include "ingest/parquet/encodings.h"
#include "ingest/parquet/parquet_file.h"
#include "tests/ingest/parquet_writer.h"

namespace wm::parquet {
namespace {
using namespace testing;  // the writer
using ::testing::ElementsAre;
using ::testing::HasSubstr;

ParquetFile Open(const std::string& bytes) { return ParquetFile::FromBytes(bytes, "t.parquet"); }

std::string Int64File(int64_t n) {
  std::vector<int64_t> v;
  for (int64_t i = 0; i < n; ++i) v.push_back(i);
  const std::string payload = PlainInt64(v);
  ChunkSpec chunk{Page({.num_values = static_cast<int32_t>(n),
                        .raw_size = static_cast<int32_t>(payload.size())},
                       payload),
                  n};
  return ParquetFileBytes({ScalarLeaf("frame_index", PhysicalType::kInt64, Repetition::kRequired)},
                          {{n, {chunk}}});
}

TEST(RleHybrid, DecodesRleAndBitPackedRuns) {
  const std::string bytes = RleRun(5, 3, 3) + BitPackedRun({1, 2, 3, 4, 5, 6, 7, 0}, 3);
  EXPECT_THAT(DecodeRleHybrid(bytes, 3, 11), ElementsAre(5, 5, 5, 1, 2, 3, 4, 5, 6, 7, 0));
  EXPECT_THAT(DecodeRleHybrid(bytes, 3, 2), ElementsAre(5, 5));  // a run longer than asked
  EXPECT_THROW(DecodeRleHybrid(bytes, 3, 12), Error);            // runs end early
  EXPECT_EQ(BitWidth(0), 0);
  EXPECT_EQ(BitWidth(3), 2);
  EXPECT_EQ(BitWidth(4), 3);
}

TEST(ParquetFile, RequiredInt64PlainV1) {
  ParquetFile f = Open(Int64File(10));
  EXPECT_EQ(f.num_rows(), 10);
  Column c = f.Read("frame_index");
  EXPECT_EQ(c.rows(), 10);
  EXPECT_EQ(c.RowSize(9), 1);
  EXPECT_THAT(c.values.ints, ElementsAre(0, 1, 2, 3, 4, 5, 6, 7, 8, 9));
}

// Optional DOUBLE with nulls, dictionary-encoded, in a snappy data page v2.
TEST(ParquetFile, OptionalDictionarySnappyPageV2) {
  ParquetFile f = Open(OptionalDictionaryFile());
  Column c = f.Read("reward");
  EXPECT_EQ(c.rows(), 6);
  EXPECT_THAT(c.row_starts, ElementsAre(0, 1, 1, 2, 3, 3, 4));  // rows 1 and 4 are null
  EXPECT_THAT(c.values.reals, ElementsAre(1.5, 2.5, 1.5, 2.5));
}

TEST(ParquetFile, ListsWithEmptyAndNullRowsAcrossPagesAndRowGroups) {
  ParquetFile f = Open(ListColumnFile());
  ASSERT_EQ(f.leaves().size(), 1u);
  EXPECT_EQ(f.leaves()[0].path, "action.list.element");
  EXPECT_EQ(f.leaves()[0].max_definition, 3);
  EXPECT_EQ(f.leaves()[0].max_repetition, 1);
  Column c = f.Read("action");
  EXPECT_THAT(c.row_starts, ElementsAre(0, 3, 3, 3, 4, 6));
  EXPECT_THAT(c.values.reals, ElementsAre(1, 2, 3, 4, 5, 6));
}

// A LeRobot v3.0 episode is read from its own row groups only.
TEST(ParquetFile, ReadsARangeOfRowGroups) {
  ParquetFile f = Open(ListColumnFile());
  EXPECT_EQ(f.GroupStart(0), 0);
  EXPECT_EQ(f.GroupStart(1), 4);
  EXPECT_EQ(f.GroupStart(2), 5);
  Column second = f.Read("action", 1, 2);
  EXPECT_THAT(second.row_starts, ElementsAre(0, 2));
  EXPECT_THAT(second.values.reals, ElementsAre(5, 6));
  EXPECT_EQ(f.Read("action", 0, 1).rows(), 4);
  EXPECT_EQ(f.Read("action", 2, 2).rows(), 0);
}

TEST(ParquetFile, NullListElementIsAnErrorNamingThePlace) {
  ParquetFile f = Open(ListColumnFile(/*null_element=*/true));
  try {
    f.Read("action");
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_THAT(e.what(), HasSubstr("t.parquet: row group 0: key 'action.list.element'"));
    EXPECT_THAT(e.what(), HasSubstr("page 0: null element inside a list"));
  }
}

TEST(ParquetFile, DamageIsAnErrorNamingFileRowGroupColumnPage) {
  const std::string good = Int64File(4);
  EXPECT_THAT([&] { Open(good.substr(0, good.size() - 1)); },
              ThrowsMessage<Error>(HasSubstr("t.parquet: not a Parquet file")));
  std::string bad = good;
  bad[4] = '\x0d';  // the page header's first field header: an unknown Thrift type
  ParquetFile f = Open(bad);
  EXPECT_THAT([&] { f.Read("frame_index"); },
              ThrowsMessage<Error>(AllOf(HasSubstr("row group 0"), HasSubstr("'frame_index'"),
                                         HasSubstr("page 0: Thrift: unknown type id 13"))));
  EXPECT_THAT([&] { f.Read("nope"); },
              ThrowsMessage<Error>(HasSubstr("no column 'nope' (columns: frame_index)")));
}

TEST(ParquetFile, UnsupportedCodecIsNamed) {
  const std::string payload = PlainInt64({7});
  ChunkSpec chunk{Page({.num_values = 1, .raw_size = 8}, payload), 1, /*codec=GZIP*/ 2};
  ParquetFile f = Open(ParquetFileBytes(
      {ScalarLeaf("x", PhysicalType::kInt64, Repetition::kRequired)}, {{1, {chunk}}}));
  EXPECT_THAT([&] { f.Read("x"); }, ThrowsMessage<Error>(HasSubstr("codec GZIP")));
}

}  // namespace
}  // namespace wm::parquet

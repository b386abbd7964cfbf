// CsvTable: the forms of CSV it accepts, and errors that name the file, line and column.
#include "metrics/value/csv_table.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>

#include "core/error.h"
#include "metrics/value/value_io.h"
#include "tests/core/test_util.h"

namespace wm::metrics {
namespace {

using ::testing::HasSubstr;

std::string ParseError(const std::string& text) {
  return test::ErrorText([&] { CsvTable::Parse(text, "t.csv"); });
}

TEST(CsvTable, ColumnsByNameQuotesBomCrlfAndBlankLines) {
  const CsvTable t = CsvTable::Parse(
      "\xEF\xBB\xBF y , x ,label\r\n\r\n 2.5 ,1e3,\"a, \"\"b\"\"\"\r\n+4,-0.5,plain\n\n", "t.csv");
  ASSERT_EQ(t.rows(), 2u);
  EXPECT_EQ(t.header(), (std::vector<std::string>{"y", "x", "label"}));
  const size_t x = t.Column("x"), y = t.Column("y"), label = t.Column("label");
  EXPECT_EQ(t.Number(0, x), 1000.0);
  EXPECT_EQ(t.Number(0, y), 2.5);
  EXPECT_EQ(t.Cell(0, label), "a, \"b\"");
  EXPECT_EQ(t.Number(1, y), 4.0);
  EXPECT_EQ(t.line(0), 3);
  EXPECT_EQ(t.line(1), 4);
  EXPECT_FALSE(t.FindColumn("z").has_value());
}

TEST(CsvTable, ErrorsNameFileLineAndColumn) {
  const CsvTable t = CsvTable::Parse("a,b\n1,2\n\n3,x\n4,nan\n5,1e999\n6,\n", "t.csv");
  EXPECT_EQ(test::ErrorText([&] { t.Number(1, 1); }),
            "t.csv: line 4: column 'b': 'x' is not a number");
  EXPECT_THAT(test::ErrorText([&] { t.Number(2, 1); }),
              HasSubstr("t.csv: line 5: column 'b': 'nan' is not finite"));
  EXPECT_THAT(test::ErrorText([&] { t.Number(3, 1); }),
              HasSubstr("t.csv: line 6: column 'b': '1e999' is not finite"));
  EXPECT_EQ(test::ErrorText([&] { t.Number(4, 1); }), "t.csv: line 7: column 'b': empty cell");
  EXPECT_EQ(test::ErrorText([&] { t.Column("c"); }),
            "t.csv: line 1: missing column 'c' (the header has: a, b)");
}

TEST(CsvTable, MalformedFilesAreErrors) {
  EXPECT_EQ(ParseError(""), "t.csv: empty file: expected a header row");
  EXPECT_EQ(ParseError("\n \n"), "t.csv: empty file: expected a header row");
  EXPECT_EQ(ParseError("a,b\n1,2,3\n"), "t.csv: line 2: 3 cells, but the header has 2 columns");
  EXPECT_EQ(ParseError("a,,b\n"), "t.csv: line 1: the header has an empty column name");
  EXPECT_EQ(ParseError("a,b,a\n"), "t.csv: line 1: the header repeats column 'a'");
  EXPECT_EQ(ParseError("a\n\"open\n"), "t.csv: line 2: unterminated quoted cell");
  EXPECT_THAT(test::ErrorText([] { CsvTable::Read("/nonexistent/r.csv"); }),
              HasSubstr("/nonexistent/r.csv: cannot open"));
}

TEST(CsvTable, WritesCellsThatReadBack) {
  EXPECT_EQ(CsvCell("plain"), "plain");
  EXPECT_EQ(CsvCell("a,\"b\""), "\"a,\"\"b\"\"\"");
  EXPECT_EQ(CsvNumber(0.1), "0.1");
  EXPECT_EQ(CsvNumber(1e21), "1e+21");
  EXPECT_EQ(CsvNumber(NAN), "");
  const CsvTable t = CsvTable::Parse("s\n" + CsvCell("a,\"b\"") + "\n", "t.csv");
  EXPECT_EQ(t.Cell(0, 0), "a,\"b\"");
}

TEST(CsvTable, ReturnsFileErrorsPointAtTheLine) {
  test::TempDir dir;
  const std::string path = dir / "returns.csv";
  std::ofstream(path) << "model_return,policy_id,real_return,episode\n1,a,1,e0\n2,a,2,e1\n"
                         "3,a,3,e0\n";
  EXPECT_EQ(test::ErrorText([&] { ComputeValueMetricsFromCsv(path, {}); }),
            path + ": line 4: episode 'e0' of policy 'a' is listed twice");
  std::ofstream(path) << "episode,policy_id,real_return\n";
  EXPECT_THAT(test::ErrorText([&] { ComputeValueMetricsFromCsv(path, {}); }),
              HasSubstr("missing column 'model_return'"));
}

}  // namespace
}  // namespace wm::metrics

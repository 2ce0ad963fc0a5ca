#include "common/csv.h"

#include <gtest/gtest.h>

#include "common/error.h"

namespace gonio {
namespace {

TEST(Csv, ReadsByHeaderSkippingCommentsAndBlankLines) {
  const auto t = CsvTable::Parse("# comment\na,b\n1,2\n\n3, 4.5\n", "t.csv");
  ASSERT_EQ(t.num_rows(), 2u);
  EXPECT_EQ(t.Require("b"), 1u);
  EXPECT_DOUBLE_EQ(t.Number(1, 1), 4.5);
  EXPECT_EQ(t.LineOf(1), 5u);
}

TEST(Csv, ErrorsNameFileLineAndColumn) {
  const auto t = CsvTable::Parse("a,b\n1,nan\n", "t.csv");
  try {
    t.Number(0, 1);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_STREQ(e.what(), "t.csv: line 2, column 'b': 'nan' is not a finite number");
  }
  EXPECT_THROW(t.Require("c"), InputError);
  EXPECT_THROW(CsvTable::Parse("a,b\n1\n", "t.csv"), InputError);
  EXPECT_THROW(CsvTable::Parse("", "t.csv"), InputError);
}

TEST(Csv, QuotedFieldsRoundTrip) {
  const auto t = CsvTable::Parse("a,b\n\"x, y\",\"say \"\"hi\"\"\"\n", "t.csv");
  EXPECT_EQ(t.Cell(0, 0), "x, y");
  EXPECT_EQ(t.Cell(0, 1), "say \"hi\"");
  EXPECT_EQ(CsvField("x, y"), "\"x, y\"");
}

}  // namespace
}  // namespace gonio

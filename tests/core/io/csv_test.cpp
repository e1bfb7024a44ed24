// CSV writing (exact round trip, atomic commit) and reading (errors naming file, line, column).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "core/io/csv.hpp"

namespace hysid {
namespace {

std::filesystem::path TempFile(const std::string& name, const std::string& text) {
  const auto dir = std::filesystem::temp_directory_path() / "hysid-test-csv";
  std::filesystem::create_directories(dir);
  const auto path = dir / name;
  std::ofstream(path) << text;
  return path;
}

TEST_CASE("doubles round-trip exactly through a CSV", "[csv]") {
  const auto path = std::filesystem::temp_directory_path() / "hysid-test-csv" / "sub" / "rt.csv";
  std::filesystem::remove(path);
  const std::vector<double> row = {0.1, 1.0 / 3.0, -2.5e-300, 6.02214076e23};
  {
    CsvWriter writer(path, {"a", "b", "c", "d"});
    writer.Row(row);
    CHECK_FALSE(std::filesystem::exists(path));  // not visible before Commit
    writer.Commit();
  }
  const CsvTable table = ReadCsv(path);
  REQUIRE(table.rows() == 1);
  for (int c = 0; c < 4; ++c) CHECK(table.columns[c][0] == row[c]);
  CHECK(table.Find("c") == 2);
  CHECK(table.Find("z") == -1);
}

TEST_CASE("bad CSV cells name file, line and column", "[csv]") {
  CHECK_THROWS_WITH(ReadCsv(TempFile("nan.csv", "t,x\n0,1\n1,nan\n")),
                    Catch::Contains("nan.csv:3") && Catch::Contains("column 2 ('x')"));
  CHECK_THROWS_WITH(ReadCsv(TempFile("word.csv", "t,x\n0,abc\n")),
                    Catch::Contains("word.csv:2") && Catch::Contains("'x'"));
  CHECK_THROWS_WITH(ReadCsv(TempFile("short.csv", "t,x\n0,1\n1\n")),
                    Catch::Contains("short.csv:3"));
  CHECK_THROWS_WITH(ReadCsv(TempFile("empty.csv", "")), Catch::Contains("empty.csv"));
  CHECK_THROWS_WITH(ReadCsv("/nonexistent/file.csv"), Catch::Contains("/nonexistent/file.csv"));
}

TEST_CASE("comments and blank lines are skipped, line numbers stay right", "[csv]") {
  const CsvTable t = ReadCsv(TempFile("comments.csv", "# made by hand\nt,x\n\n0,1\n# note\n1,2\n"));
  REQUIRE(t.rows() == 2);
  CHECK(t.line_of_row == std::vector<long>{4, 6});
  CHECK(t.columns[1][1] == 2.0);
}

}  // namespace
}  // namespace hysid

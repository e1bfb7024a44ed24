// CSV writing (exact round trip, atomic commit) and reading (errors naming file, line, column).
#include <catch2/catch.hpp>

#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/io/csv.hpp"
#include "core/io/files.hpp"
#include "core/io/limits.hpp"
#include "tests/testing/temp_dir.hpp"

namespace hysid {
namespace {

std::filesystem::path TempFile(const std::string& name, const std::string& text) {
  static const auto dir = testing::FreshTempDir("csv");
  const auto path = dir / name;
  std::ofstream(path) << text;
  return path;
}

TEST_CASE("doubles round-trip exactly through a CSV", "[csv]") {
  const auto path = testing::FreshTempDir("csv-rt") / "sub" / "rt.csv";
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
  CHECK_THROWS_WITH(
      ReadCsv(TempFile("inf.csv", "t,x\n0,1\n1,-inf\n")),
      Catch::Contains("inf.csv:3") && Catch::Contains("column 2 ('x')") && Catch::Contains("not finite"));
  CHECK_THROWS_WITH(ReadCsv(TempFile("word.csv", "t,x\n0,abc\n")),
                    Catch::Contains("word.csv:2") && Catch::Contains("'x'"));
  CHECK_THROWS_WITH(ReadCsv(TempFile("short.csv", "t,x\n0,1\n1\n")), Catch::Contains("short.csv:3"));
  CHECK_THROWS_WITH(ReadCsv(TempFile("empty.csv", "")), Catch::Contains("empty.csv"));
  CHECK_THROWS_WITH(ReadCsv("/nonexistent/file.csv"), Catch::Contains("/nonexistent/file.csv"));
}

TEST_CASE("comments and blank lines are skipped, line numbers stay right", "[csv]") {
  const CsvTable t = ReadCsv(TempFile("comments.csv", "# made by hand\nt,x\n\n0,1\n# note\n1,2\n"));
  REQUIRE(t.rows() == 2);
  CHECK(t.line_of_row == std::vector<long>{4, 6});
  CHECK(t.columns[1][1] == 2.0);
}

// RLIMIT_FSIZE makes writes beyond `bytes` fail with EFBIG (SIGXFSZ ignored): a short write without
// root or a full disk. Restores the limit on destruction.
struct FileSizeLimit {
  rlimit old{};
  explicit FileSizeLimit(rlim_t bytes) {
    std::signal(SIGXFSZ, SIG_IGN);
    getrlimit(RLIMIT_FSIZE, &old);
    rlimit lim = old;
    lim.rlim_cur = bytes;
    setrlimit(RLIMIT_FSIZE, &lim);
  }
  ~FileSizeLimit() { setrlimit(RLIMIT_FSIZE, &old); }
};

// No temporary file (NAME.<pid>-<n>.tmp) left in `dir`.
bool NoTemporaries(const std::filesystem::path& dir) {
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (e.path().extension() == ".tmp") return false;
  }
  return true;
}

TEST_CASE("a failed write names errno and leaves no temporary file", "[csv][files]") {
  const auto dir = testing::FreshTempDir("csv-short");
  std::filesystem::remove_all(dir);
  const auto path = dir / "big.csv";
  std::string message;
  {
    CsvWriter writer(path, {"a", "b"});
    const FileSizeLimit limit(64 * 1024);
    try {
      for (int i = 0; i < 100000; ++i) writer.Row(std::vector<double>{1.0 / 3.0, static_cast<double>(i)});
      writer.Commit();
    } catch (const std::runtime_error& e) {
      message = e.what();
    }
  }
  CHECK_THAT(message, Catch::Contains("big.csv: write failed: File too large"));
  CHECK_FALSE(std::filesystem::exists(path));
  CHECK(NoTemporaries(dir));
  // The same through WriteFileAtomically.
  {
    const FileSizeLimit limit(1000);
    CHECK_THROWS_WITH(WriteFileAtomically(dir / "meta.json", std::string(5000, 'x')),
                      Catch::Contains("meta.json: write failed: File too large"));
  }
  CHECK(NoTemporaries(dir));
  CHECK_FALSE(std::filesystem::exists(dir / "meta.json"));
  // A rename onto a non-empty directory fails: errno text, temporary removed.
  std::filesystem::create_directories(dir / "taken" / "inside");
  {
    CsvWriter writer(dir / "taken", {"a"});
    CHECK_THROWS_WITH(writer.Commit(),
                      Catch::Contains("taken: cannot rename the temporary file onto it: Is a directory"));
  }
  CHECK(NoTemporaries(dir));
  // Checked before any computation: a directory, a file as directory.
  CHECK_THROWS_WITH(CheckOutputPath("--trace", dir),
                    Catch::Contains("--trace") && Catch::Contains("is a directory"));
  std::ofstream(dir / "plain") << "x";
  CHECK_THROWS_WITH(CheckOutputPath("--trace", dir / "plain" / "x.csv"),
                    Catch::Contains("--trace") && Catch::Contains("exists and is not a directory"));
}

// A full disk at every size of the new content: the older good file stays whole, never a 0-byte or
// truncated one, and no temporary file is left.
TEST_CASE("a failed rewrite keeps the older file byte for byte", "[files]") {
  const auto dir = testing::FreshTempDir("files-keep");
  const auto path = dir / "result.json";
  const std::string good = "{\"a good\": \"result\"}\n";
  WriteFileAtomically(path, good);
  for (const rlim_t limit : {rlim_t{0}, rlim_t{1}, rlim_t{100}, rlim_t{4095}, rlim_t{65536}}) {
    INFO("file size limit " << limit);
    {
      const FileSizeLimit full(limit);
      CHECK_THROWS_WITH(WriteFileAtomically(path, std::string(100000, 'x')),
                        Catch::Contains("result.json: write failed: File too large"));
      CHECK_THROWS_WITH(
          [&] {
            CsvWriter csv(path, {"a"});
            for (int i = 0; i < 20000; ++i) csv.Row(std::vector<double>{1.0 / 3.0});
            csv.Commit();
          }(),
          Catch::Contains("result.json: write failed: File too large"));
    }
    std::ifstream in(path);
    CHECK(std::string(std::istreambuf_iterator<char>(in), {}) == good);
    CHECK(NoTemporaries(dir));
  }
}

// An output that is an input is refused however it is spelled: the same name, another relative
// spelling, an absolute path, a hard link, a symbolic link, a link to its directory.
TEST_CASE("an output that is one of the inputs is refused under every name", "[files]") {
  namespace fs = std::filesystem;
  const auto dir = fs::canonical(testing::FreshTempDir("files-inputs"));
  fs::create_directories(dir / "sub");
  std::ofstream(dir / "sub" / "data.csv") << "t,y1\n0,1\n";
  fs::create_hard_link(dir / "sub" / "data.csv", dir / "hard.csv");
  fs::create_symlink(dir / "sub" / "data.csv", dir / "soft.csv");
  fs::create_directory_symlink(dir / "sub", dir / "subdir-link");
  InputFiles inputs;
  inputs.Add("--data", dir / "sub" / "data.csv");
  inputs.Add("--model-file", dir / "no-such.toml");  // a missing input is its reader's error
  for (const fs::path& name : {dir / "sub" / "data.csv", dir / "sub" / ".." / "sub" / "data.csv",
                               dir / "hard.csv", dir / "soft.csv", dir / "subdir-link" / "data.csv"}) {
    INFO(name);
    CHECK_THROWS_WITH(CheckOutputPath("--json", name, inputs),
                      Catch::Contains("--json " + name.string() + ": is the input --data"));
  }
  CHECK_NOTHROW(CheckOutputPath("--json", dir / "sub" / "other.csv", inputs));
  CHECK_NOTHROW(CheckOutputPath("--json", dir / "no-such.toml", inputs));
  CHECK_THROWS_WITH(CheckOutputPaths({{"--trace", dir / "a.csv"}, {"--hulls", dir / "sub" / ".." / "a.csv"}}),
                    Catch::Contains("--hulls") && Catch::Contains("the same file as --trace"));
}

// Any text survives a write and a read as one cell: commas, quotes, line breaks, edge spaces.
TEST_CASE("names are quoted per RFC 4180 and read back as written", "[csv]") {
  const std::vector<std::string> names{"wall,msd", "say \"hi\"", "two\nlines", "cr\rmid", " edge ", "\t",
                                       "",         "\"",          ",",            "plain",     "k_hat"};
  for (const std::string& a : names) {
    for (const std::string& b : names) {
      const std::vector<std::string> cells{a, b, "1"};
      std::vector<std::string> back;
      REQUIRE(SplitCsvRecord(JoinCsvRecord(cells), "t", 1, &back));
      CHECK(back == cells);
    }
  }
  CHECK(CsvCell("plain") == "plain");
  CHECK(CsvCell("wall,msd") == "\"wall,msd\"");
  CHECK(CsvCell("a\"b") == "\"a\"\"b\"");
  // Through a file: the header and a text row, read back record by record across the line breaks.
  const auto path = testing::FreshTempDir("csv-names") / "names.csv";
  {
    CsvWriter csv(path, names);
    csv.TextRow(names);
    csv.Commit();
  }
  std::ifstream in(path, std::ios::binary);
  long line = 0;
  std::vector<std::string> cells;
  for (int record = 0; record < 2; ++record) {
    REQUIRE(ReadCsvRecord(in, "names.csv", &line, &cells));
    CHECK(cells == names);
  }
  CHECK_FALSE(ReadCsvRecord(in, "names.csv", &line, &cells));
}

TEST_CASE("headers must be headers: numbers and empty names are refused", "[csv]") {
  std::istringstream empty("t,,y\n0,1,2\n");
  CHECK_THROWS_WITH(ReadCsvStream(empty, "e.csv"),
                    Catch::Contains("e.csv:1: column 2 of the header is empty"));
  std::istringstream numbers("# comment\n0,20,0\n1,19,1\n");
  CHECK_THROWS_WITH(ReadCsvStream(numbers, "n.csv"),
                    Catch::Contains("n.csv:2: the first line is numbers, not a header"));
  std::istringstream fine("t,y1\n0,1e308\n");
  CHECK(ReadCsvStream(fine, "f.csv").columns[1][0] == 1e308);
}

TEST_CASE("RFC 4180: quoted fields, doubled quotes, commas and line breaks inside quotes, CRLF", "[csv]") {
  std::vector<std::string> cells;
  REQUIRE(SplitCsvRecord(R"(a,"b,c","say ""hi""",  d ,"")", "r.csv", 1, &cells));
  CHECK(cells == std::vector<std::string>{"a", "b,c", "say \"hi\"", "d", ""});
  REQUIRE(SplitCsvRecord("x,", "r.csv", 1, &cells));  // a trailing comma: an empty last field
  CHECK(cells == std::vector<std::string>{"x", ""});
  REQUIRE(SplitCsvRecord(R"(5"5,ok)", "r.csv", 1, &cells));  // a quote inside an unquoted field is text
  CHECK(cells == std::vector<std::string>{"5\"5", "ok"});
  CHECK_FALSE(SplitCsvRecord(R"(a,"open)", "r.csv", 1, &cells));  // ends inside quotes
  CHECK_THROWS_WITH(SplitCsvRecord(R"(a,"b"c,d)", "r.csv", 7, &cells),
                    Catch::Contains("r.csv:7: column 2: text 'c' after the closing quote"));
  CHECK_THROWS_WITH(SplitCsvLine(R"(1,"2)", "j.csv", 3), "j.csv:3: column 2: the quoted cell is not closed");
  // A table: a comma in a quoted name, CRLF line ends, a quoted number, a line break inside a quoted
  // header cell (a row is numbered by its record's first line), comments outside records.
  std::istringstream in(
      "# made by a logger\r\n\"time, s\",\"x\r\nmetres\",v\r\n0,\"1.5\",2\r\n\r\n1, 2 ,\" 3\"\r\n");
  const CsvTable t = ReadCsvStream(in, "rfc.csv");
  CHECK(t.header == std::vector<std::string>{"time, s", "x\nmetres", "v"});
  REQUIRE(t.rows() == 2);
  CHECK(t.columns[1][0] == 1.5);
  CHECK(t.columns[2][1] == 3.0);
  CHECK(t.line_of_row == std::vector<long>{4, 6});
  std::istringstream open("t,x\n0,\"1\n");
  CHECK_THROWS_WITH(ReadCsvStream(open, "o.csv"),
                    "o.csv:2: column 2: the quoted cell is not closed before the end of the file");
}

TEST_CASE("missing cells (empty, nan, NA) are NaN and counted - words and infinities are refused", "[csv]") {
  std::istringstream in("t,x,y\n0,,1\n1,nan,NA\n2,\"\",-nan\n3,4,5\n");
  const CsvTable t = ReadCsvStream(in, "m.csv");
  REQUIRE(t.rows() == 4);
  CHECK(t.missing_cells == 5);
  CHECK(std::isnan(t.columns[1][0]));
  CHECK(std::isnan(t.columns[2][1]));
  CHECK(std::isnan(t.columns[2][2]));
  CHECK(t.columns[1][3] == 4.0);
  std::istringstream word("t,x\n0,N/A\n");
  CHECK_THROWS_WITH(ReadCsvStream(word, "w.csv"), "w.csv:2: column 2 ('x'): 'N/A' is not a number");
  std::istringstream inf("t,x\n0,inf\n");
  CHECK_THROWS_WITH(ReadCsvStream(inf, "i.csv"), "i.csv:2: column 2 ('x'): 'inf' is not finite");
}

TEST_CASE("lines and cells are bounded before a line is split - messages never echo a huge cell",
          "[csv][limits]") {
  const std::string big(2u << 20, '7');  // 2 MiB of digits, beyond the default line limit
  std::istringstream long_line("t,y\n0," + big + "\n");
  try {
    ReadCsvStream(long_line, "l.csv");
    FAIL("no error");
  } catch (const std::invalid_argument& e) {
    CHECK_THAT(e.what(),
               Catch::Contains("l.csv:2: the line is longer than the limit of 1048576 bytes per CSV line") &&
                   Catch::Contains("HYSID_MAX_CSV_LINE"));
    CHECK(std::string(e.what()).size() < 300);
  }
  ::setenv("HYSID_MAX_CSV_LINE", "10000000", 1);
  std::istringstream long_cell("t,y\n0," + big + "\n");
  try {
    ReadCsvStream(long_cell, "c.csv");
    FAIL("no error");
  } catch (const std::invalid_argument& e) {
    CHECK_THAT(e.what(), Catch::Contains("c.csv:2: column 2: the cell '7777") &&
                             Catch::Contains("(2097152 bytes)") && Catch::Contains("HYSID_MAX_CSV_CELL"));
    CHECK(std::string(e.what()).size() < 300);
  }
  ::setenv("HYSID_MAX_CSV_LINE", "many", 1);
  std::istringstream any("t\n0\n");
  CHECK_THROWS_WITH(ReadCsvStream(any, "a.csv"),
                    Catch::Contains("HYSID_MAX_CSV_LINE = 'many': must be a positive integer"));
  ::unsetenv("HYSID_MAX_CSV_LINE");
  // A non-numeric cell is echoed cut to 60 bytes.
  std::istringstream word("t\n" + std::string(1000, 'x') + "\n");
  CHECK_THROWS_WITH(ReadCsvStream(word, "w.csv"), Catch::Contains("… (1000 bytes)' is not a number"));
}

TEST_CASE("bytes echoed in a message are printable: control and invalid UTF-8 bytes as hex escapes", "[csv]") {
  std::istringstream binary(std::string("t,y\n0,1\n\x01\x02", 10) + std::string(1, '\0') + ",\xff\xfe\n");
  CHECK_THROWS_WITH(ReadCsvStream(binary, "b.csv"),
                    "b.csv:3: column 1 ('t'): '\\x01\\x02\\x00' is not a number");
  CHECK(Printable("a\tb\x7f") == "a\\x09b\\x7f");
  CHECK(Printable("\xc3\xbb ok \xc3") == "\xc3\xbb ok \\xc3");  // û kept, a cut sequence escaped
  CHECK(Printable("\xe2\x88") == "\\xe2\\x88");
  CHECK(Abbreviated(std::string(100, '\n'), 2) == "\\x0a\\x0a… (100 bytes)");
}

}  // namespace
}  // namespace hysid

namespace hysid {
namespace {

TEST_CASE("records end at LF, CR LF or a lone CR - a byte order mark is skipped", "[csv]") {
  for (const std::string& text :
       {std::string("t,x\n0,1\n1,2\n"), std::string("t,x\r\n0,1\r\n1,2\r\n"), std::string("t,x\r0,1\r1,2\r"),
        std::string("\xEF\xBB\xBFt,x\n0,1\n1,2\n")}) {
    std::istringstream in(text);
    const CsvTable t = ReadCsvStream(in, "e.csv");
    CHECK(t.header == std::vector<std::string>{"t", "x"});
    REQUIRE(t.rows() == 2);
    CHECK(t.columns[1][1] == 2.0);
    CHECK(t.line_of_row == std::vector<long>{2, 3});
  }
}

TEST_CASE("a FIFO is refused before it is opened (reading it would block)", "[csv]") {
  const std::string fifo = "csv_test_fifo.csv";
  ::unlink(fifo.c_str());
  REQUIRE(::mkfifo(fifo.c_str(), 0600) == 0);
  CHECK_THROWS_WITH(ReadCsv(fifo),
                    "csv_test_fifo.csv: is a FIFO, not a regular file; give the data file as a file");
  CHECK_THROWS_WITH(ReadWholeFile(fifo, "sweep file"),
                    "csv_test_fifo.csv: is a FIFO, not a regular file; give the sweep file as a file");
  ::unlink(fifo.c_str());
  CHECK_THROWS_WITH(ReadWholeFile("/dev/zero", "model file"), Catch::Contains("is a character device"));
}

TEST_CASE("model and sweep files are read up to their size limit", "[csv]") {
  const std::string path = "csv_test_input.toml";
  std::ofstream(path) << std::string(200, '#');
  CHECK(ReadWholeFile(path, "model file").size() == 200);
  ::setenv("HYSID_MAX_INPUT_FILE", "100", 1);
  CHECK_THROWS_WITH(
      ReadWholeFile(path, "model file"),
      "csv_test_input.toml: the model file is longer than the limit of 100 bytes per model or sweep "
      "file (raise it with HYSID_MAX_INPUT_FILE=N)");
  ::setenv("HYSID_MAX_INPUT_FILE", "200", 1);
  CHECK(ReadWholeFile(path, "model file").size() == 200);
  ::unsetenv("HYSID_MAX_INPUT_FILE");
  ::unlink(path.c_str());
}

}  // namespace
}  // namespace hysid

// Sample data: runs, chains (missing rows, gaps), irregular steps, column choice, and the refusals that
// name file, line and column.
#include <catch2/catch.hpp>

#include <cmath>
#include <cstdlib>
#include <fstream>
#include <random>
#include <sstream>
#include <tuple>

#include <fmt/format.h>

#include "core/io/sample_data.hpp"
#include "tests/testing/temp_dir.hpp"

namespace hysid {
namespace {

CsvTable Table(const std::string& text, const std::string& name = "d.csv") {
  std::istringstream in(text);
  return ReadCsvStream(in, name);
}

TEST_CASE("uniform data: one run, one chain, the mean step", "[sample_data]") {
  const SampleData d = SampleDataFromTable(Table("t,j,y1,y2\n0,0,1,2\n0.5,0,3,4\n1,1,5,6\n"), 2);
  CHECK(d.uniform);
  CHECK(d.dt == 0.5);
  CHECK(d.chains() == 1);
  CHECK(d.state_columns == std::vector<std::string>{"y1", "y2"});
  CHECK(d.y(1, 2) == 6.0);
  REQUIRE(d.j);
  CHECK(*d.j == std::vector<int>{0, 0, 1});
}

TEST_CASE("a missing state cell drops its row and the chain goes on - a long step starts a chain",
          "[sample_data]") {
  // Steps 0.1 (0.2 across a dropped row) except one of 0.7 (> 5 × the median 0.1): chains at sample 0
  // and at t = 1.5.
  const std::string text =
      "t,x,v\n0,1,2\n0.1,1,2\n0.2,,2\n0.3,1,2\n0.4,1,NA\n0.5,1,2\n0.6,1,2\n0.7,1,2\n0.8,1,2\n1.5,1,2\n"
      "1.6,1,2\n";
  const SampleData d = SampleDataFromTable(Table(text), 2);
  CHECK_FALSE(d.uniform);
  CHECK(d.missing_rows == 2);
  CHECK(d.first_missing_line == 4);
  CHECK(d.gaps == 1);
  CHECK(d.dt == Approx(0.1));
  CHECK(d.max_gap == Approx(0.5));
  CHECK(d.t == std::vector<double>{0, 0.1, 0.3, 0.5, 0.6, 0.7, 0.8, 1.5, 1.6});
  CHECK(d.chain_start == std::vector<std::uint8_t>{1, 0, 0, 0, 0, 0, 0, 1, 0});
  CHECK(d.line == std::vector<long>{2, 3, 5, 7, 8, 9, 10, 11, 12});
  // A larger maximum gap keeps t = 1.5 in its chain; a smaller one cuts at the dropped rows too.
  const SampleData wide = SampleDataFromTables({Table(text)}, 2, {.max_gap = 1.0});
  CHECK(wide.gaps == 0);
  CHECK(wide.chains() == 1);
  const SampleData narrow = SampleDataFromTables({Table(text)}, 2, {.max_gap = 0.15});
  CHECK(narrow.chain_start == std::vector<std::uint8_t>{1, 0, 1, 1, 0, 0, 0, 1, 0});
}

TEST_CASE("irregular steps are accepted - time must still increase", "[sample_data]") {
  const SampleData d = SampleDataFromTable(Table("t,x,v\n0,1,2\n0.101,1,2\n0.199,1,2\n0.3,1,2\n"), 2);
  CHECK_FALSE(d.uniform);
  CHECK(d.chains() == 1);
  CHECK(d.dt == Approx(0.101));  // the median of 0.101, 0.098, 0.101
  CHECK_THROWS_WITH(SampleDataFromTable(Table("t,x,v\n0,1,2\n0.1,1,2\n0.1,1,2\n", "b.csv"), 2),
                    "b.csv:4: column 1 ('t'): time 0.1 is not after 0.1 (line 3): time must increase");
  CHECK_THROWS_WITH(SampleDataFromTable(Table("t,x,v\n0,1,2\n,1,2\n0.2,1,2\n", "m.csv"), 2),
                    "m.csv:3: column 1 ('t'): the time is missing");
}

TEST_CASE("several runs: files and a run column - each run starts a chain and its own clock",
          "[sample_data]") {
  const CsvTable a = Table("t,j,x,v\n0,0,1,2\n0.1,0,1,2\n0.2,1,1,2\n", "a.csv");
  const CsvTable b = Table("run,t,j,x,v\n7,0,0,5,6\n7,0.1,1,5,6\n3,0,0,8,9\n3,0.1,0,8,9\n", "b.csv");
  const SampleData d = SampleDataFromTables({a, b}, 2);
  CHECK(d.run_names == std::vector<std::string>{"a.csv", "b.csv run 7", "b.csv run 3"});
  CHECK(d.run == std::vector<int>{0, 0, 0, 1, 1, 2, 2});
  CHECK(d.chain_start == std::vector<std::uint8_t>{1, 0, 0, 1, 0, 1, 0});
  CHECK(d.path == "a.csv, b.csv");
  CHECK(d.state_columns == std::vector<std::string>{"x", "v"});
  REQUIRE(d.j);  // jump counters continue across runs, so no run start looks like a jump
  CHECK(*d.j == std::vector<int>{0, 0, 1, 1, 2, 2, 2});
  CHECK_THROWS_WITH(SampleDataFromTable(Table("run,t,x,v\n1,0,1,2\n2,0,1,2\n1,0.1,1,2\n", "r.csv"), 2),
                    "r.csv:4: column 1 ('run'): run 1 appears again after run 2; the rows of a run must be "
                    "contiguous");
  CHECK_THROWS_WITH(SampleDataFromTable(Table("run,t,x,v\n1.5,0,1,2\n", "f.csv"), 2),
                    "f.csv:2: column 1 ('run'): 1.5 is not a run number (an integer)");
}

TEST_CASE("columns by name: t=, run= and the states in model order", "[sample_data]") {
  const CsvTable t = Table("v,time,id,x\n2,0,1,1\n3,0.1,1,1.5\n4,0.2,2,0\n5,0.3,2,0.5\n", "c.csv");
  const SampleData d = SampleDataFromTables({t}, 2, {.columns = {"t=time", "x", "v", "run=id"}});
  CHECK(d.state_columns == std::vector<std::string>{"x", "v"});
  CHECK(d.y(0, 1) == 1.5);
  CHECK(d.y(1, 3) == 5.0);
  CHECK(d.t == std::vector<double>{0, 0.1, 0.2, 0.3});
  CHECK(d.run_names.size() == 2);
  CHECK_THROWS_WITH(SampleDataFromTables({t}, 2, {.columns = {"t=time", "pos", "v"}}),
                    "c.csv:1: SampleDataOptions::columns: no column 'pos' (the columns are v,time,id,x)");
  CHECK_THROWS_WITH(SampleDataFromTables({t}, 2, {.columns = {"x"}}),
                    "c.csv:1: SampleDataOptions::columns: 1 state columns named (x); the model has 2 states");
}

TEST_CASE("too few samples after the missing rows are left out", "[sample_data]") {
  CHECK_THROWS_WITH(
      SampleDataFromTable(Table("t,x,v\n0,1,2\n0.1,nan,2\n0.2,1,2\n", "s.csv"), 2),
      "s.csv: 2 samples (1 row with a missing value left out); the identifier needs at least 3");
}

// A file of several that holds no sample (a header only, or only rows with a missing value) is
// refused by name, wherever it stands, not left out while the others are read.
// A CSV of `runs` runs of `rows` rows each: run, t, j, x, v and an unused column.
std::string WriteRuns(const std::filesystem::path& path, int runs, int rows) {
  std::ofstream out(path);
  out << "run,t,j,x,v,true_x\n";
  for (int r = 0; r < runs; ++r) {
    for (int k = 0; k < rows; ++k) out << fmt::format("{},{},{},{},{},0\n", r, 1e-3 * k, k / 700, 1.0 + k, -2.0 * k);
  }
  return path.string();
}

TEST_CASE("read samples hold their arrays without slack: 41 bytes per sample for two states, j and runs",
          "[sample_data]") {
  const std::filesystem::path dir = testing::FreshTempDir("sample_data_bytes");
  // t 8 + y 2 × 8 + j 4 + run 4 + chain_start 1 + line 8 bytes per sample; a vector grown by doubling
  // would hold up to twice that (3000 samples: capacity 4096).
  constexpr std::size_t kPerSample = 8 + 16 + 4 + 4 + 1 + 8;
  const SampleData one = ReadSampleData({WriteRuns(dir / "a.csv", 2, 1500)}, 2, {});
  REQUIRE(one.t.size() == 3000);
  CHECK(one.run_names.size() == 2);
  CHECK(one.HeldBytes() == kPerSample * 3000);
  const SampleData two = ReadSampleData({WriteRuns(dir / "a.csv", 2, 1500), WriteRuns(dir / "b.csv", 1, 1333)}, 2, {});
  REQUIRE(two.t.size() == 4333);
  CHECK(two.HeldBytes() == kPerSample * 4333);
  CHECK(two.y(1, 3000) == 0.0);
  CHECK(two.y(0, 4332) == 1333.0);
  CHECK((*two.j)[3000] == (*two.j)[2999]);  // the second file's first run continues the counter
  std::filesystem::remove_all(dir);
}

TEST_CASE("a file streamed row by row gives the samples and the errors of its table read whole", "[sample_data]") {
  const std::filesystem::path dir = testing::FreshTempDir("sample_data_stream");
  auto write = [&](const std::string& name, const std::string& text) {
    std::ofstream(dir / name) << text;
    return (dir / name).string();
  };
  const std::string text =
      "# runs\nrun,t,j,x,v,u\n3,0,4,1,2,0.5\n3,0.1,4,,2,0.5\n3,0.2,5,1.5,2,0.5\n\n3,0.3,5,1,2,NA\n"
      "7,0,0,1,-2,1\n7,0.1,1,\"2\",-3,1\n7,0.9,1,3,-4,1\n";
  const SampleDataOptions options{.inputs = {"u"}};
  const std::string a = write("a.csv", text), b = write("b.csv", text);
  const SampleData streamed = ReadSampleData({a, b}, 2, options);
  const SampleData whole = SampleDataFromTables({ReadCsv(a), ReadCsv(b)}, 2, options);
  CHECK(streamed.t == whole.t);
  CHECK(streamed.y == whole.y);
  CHECK(streamed.u == whole.u);
  CHECK(*streamed.j == *whole.j);
  CHECK(streamed.run == whole.run);
  CHECK(streamed.chain_start == whole.chain_start);
  CHECK(streamed.line == whole.line);
  CHECK(streamed.run_names == whole.run_names);
  CHECK(streamed.missing_rows == 4);
  CHECK(streamed.missing.size() == whole.missing.size());
  CHECK(streamed.gaps == whole.gaps);
  CHECK(streamed.line == std::vector<long>{3, 5, 8, 9, 10, 3, 5, 8, 9, 10});
  for (const char* bad :
       {"t,x,v\n0,1,2\n0.1,1,2\n0.1,1,2\n", "t,j,x,v\n0,2,1,2\n0.1,1,1,2\n0.2,1,1,2\n",
        "run,t,x,v\n1,0,1,2\n2,0,1,2\n1,0.1,1,2\n", "t,x,v\n0,1,2\n0.1,1e200,2\n", "t,x,v\n0,1,2\n,1,2\n"}) {
    const std::string path = write("bad.csv", bad);
    std::string whole_error;
    try {
      SampleDataFromTables({ReadCsv(path)}, 2, {});
    } catch (const std::invalid_argument& e) {
      whole_error = e.what();
    }
    REQUIRE(!whole_error.empty());
    CHECK_THROWS_WITH(ReadSampleData({path}, 2, {}), whole_error);
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("a data file without samples is refused by name, also beside other files", "[sample_data]") {
  const CsvTable good = Table("t,x,v\n0,1,2\n0.1,1,2\n0.2,1,2\n0.3,1,2\n", "good.csv");
  const CsvTable header = Table("t,x,v\n", "header.csv");
  const CsvTable blank = Table("t,x,v\n\n# a comment\n", "blank.csv");
  const CsvTable missing = Table("t,x,v\n0,nan,2\n0.1,1,NA\n", "missing.csv");
  const std::string no_rows = ": no samples (no data rows)";
  CHECK_THROWS_WITH(SampleDataFromTables({good, header}, 2, {}), "header.csv" + no_rows);
  CHECK_THROWS_WITH(SampleDataFromTables({header, good}, 2, {}), "header.csv" + no_rows);
  CHECK_THROWS_WITH(SampleDataFromTables({good, blank, good}, 2, {}), "blank.csv" + no_rows);
  CHECK_THROWS_WITH(SampleDataFromTables({good, missing}, 2, {}),
                    "missing.csv: no samples (each of its 2 rows has a missing state value)");
  CHECK(SampleDataFromTables({good, good}, 2, {}).t.size() == 8);
  CHECK_THROWS_WITH(SampleDataFromArrays({{}, {}}, {Mat::Ones(2, 4), Mat(2, 0)}, 1e-3),
                    "run 2: no samples (no data rows)");
}

}  // namespace
}  // namespace hysid

namespace hysid {
namespace {

TEST_CASE("the jump counters of several runs join without a step whatever each starts at - j never falls",
          "[sample_data]") {
  // The second file is a later part of the run (its counter starts at 5): no jump at the boundary.
  const CsvTable a = Table("t,j,x,v\n0,0,1,2\n0.1,1,1,2\n0.2,1,1,2\n", "a.csv");
  const CsvTable b = Table("t,j,x,v\n7,5,1,2\n7.1,5,1,2\n7.2,6,1,2\n", "b.csv");
  const SampleData d = SampleDataFromTables({a, b}, 2);
  REQUIRE(d.j);
  CHECK(*d.j == std::vector<int>{0, 1, 1, 1, 1, 2});
  // Counters near 2^31 − 1 in each file: joined in 64 bits, refused when the sum does not fit.
  const CsvTable big = Table("t,j,x,v\n0,0,1,2\n0.1,2147483000,1,2\n0.2,2147483000,1,2\n", "big.csv");
  const CsvTable more = Table("t,j,x,v\n0,0,1,2\n0.1,2147483000,1,2\n", "more.csv");
  CHECK_THROWS_WITH(
      SampleDataFromTables({big, more}, 2),
      "more.csv:3: column 2 ('j'): the runs' jump counters add up to 4294966000, beyond 2147483647");
  CHECK_THROWS_WITH(
      SampleDataFromTable(Table("t,j,x,v\n0,2,1,2\n0.1,1,1,2\n0.2,1,1,2\n", "f.csv"), 2),
      "f.csv:3: column 2 ('j'): 1 after 2 (line 2): a jump counter never decreases within a run");
}

TEST_CASE("two columns of one name, and steps below the smallest, are refused by line and column",
          "[sample_data]") {
  CHECK_THROWS_WITH(SampleDataFromTable(Table("t,y1,y1,y2\n0,1,1,2\n0.1,1,1,2\n0.2,1,1,2\n", "c.csv"), 2),
                    "c.csv:1: column 3 ('y1'): the same name as column 2; column names must be unique");
  CHECK_THROWS_WITH(
      SampleDataFromTable(Table("t,x,v\n0,1,2\n1e-160,1,2\n1,1,2\n", "s.csv"), 2),
      "s.csv:3: column 1 ('t'): the step 1e-160 after line 2 is below 1e-150 s (rescale the time)");
}

TEST_CASE("columns named after the model's states are the measured state - true_* never is", "[sample_data]") {
  // `hysid simulate`'s file: t, j, the noise-free state true_x, true_v, the measured x, v.
  const std::string sim = "t,j,true_x,true_v,x,v\n0,0,1,2,1.5,2.5\n0.1,0,1,2,1.5,2.5\n0.2,0,1,2,1.5,2.5\n";
  const SampleDataOptions named{.state_names = {"x", "v"}};
  const SampleData d = SampleDataFromTables({Table(sim)}, 2, named);
  CHECK(d.state_columns == std::vector<std::string>{"x", "v"});
  CHECK(d.y(0, 0) == 1.5);
  // Other state names: not x, v by name, nor true_x, true_v by position, but the first two others.
  const SampleData other = SampleDataFromTables({Table(sim)}, 2, {.state_names = {"p", "q"}});
  CHECK(other.state_columns == std::vector<std::string>{"x", "v"});
  // Older output (x1, x2 true, y1, y2 measured) and models whose states are in another order.
  const std::string old = "t,j,x1,x2,y1,y2\n0,0,1,2,1.5,2.5\n0.1,0,1,2,1.5,2.5\n0.2,0,1,2,1.5,2.5\n";
  CHECK(SampleDataFromTables({Table(old)}, 2, named).state_columns == std::vector<std::string>{"y1", "y2"});
  CHECK(SampleDataFromTables({Table(sim)}, 2, {.state_names = {"v", "x"}}).y(0, 0) == 2.5);
  // Both sets, different columns: which one is measured would be a guess.
  CHECK_THROWS_WITH(
      SampleDataFromTables({Table("t,x,v,y1,y2\n0,1,2,1,2\n0.1,1,2,1,2\n0.2,1,2,1,2\n", "b.csv")}, 2, named),
      "b.csv:1: SampleDataOptions::columns: both the columns named after the model's states (x,v) and y1..y2 "
      "are present; name the measured state columns");
  // A state named like the time column is not matched by name.
  CHECK(SampleDataFromTables({Table("t,a,b\n0,1,2\n0.1,1,2\n0.2,1,2\n")}, 2, {.state_names = {"t", "a"}})
            .state_columns == std::vector<std::string>{"a", "b"});
}

TEST_CASE("the rows left out for a missing value are listed with their run, line and time", "[sample_data]") {
  const CsvTable a = Table(
      "run,t,x,v\n1,0,1,2\n1,0.1,,2\n1,0.2,1,2\n1,0.3,1,2\n2,0,NA,2\n2,0.1,1,2\n2,0.2,1,2\n"
      "2,0.3,1,2\n",
      "r.csv");
  const SampleData d = SampleDataFromTables({a}, 2);
  REQUIRE(d.missing.size() == 2);
  CHECK(d.missing_rows == 2);
  CHECK((d.missing[0].run == 0 && d.missing[0].line == 3 && d.missing[0].t == 0.1));
  CHECK((d.missing[1].run == 1 && d.missing[1].line == 6 && d.missing[1].t == 0.0));
  CHECK(d.t.size() + d.missing.size() == 8);  // every data row
}

TEST_CASE("arrays (the Python module) pass the same count and limit checks as files", "[sample_data]") {
  CHECK_THROWS_WITH(SampleDataFromArrays({{}}, {Mat(2, 0)}, 1e-3),
                    "run 1: 0 samples; the identifier needs at least 3");
  CHECK_THROWS_WITH(SampleDataFromArrays({{}}, {Mat::Ones(2, 1)}, 1e-3),
                    "run 1: 1 samples; the identifier needs at least 3");
  ::setenv("HYSID_MAX_SAMPLES", "4", 1);
  CHECK_THROWS_WITH(SampleDataFromArrays({{}}, {Mat::Ones(2, 5)}, 1e-3),
                    Catch::Contains("y: 5 exceeds the limit of 4 samples per trajectory"));
  ::unsetenv("HYSID_MAX_SAMPLES");
}

}  // namespace
}  // namespace hysid

namespace hysid {
namespace {

TEST_CASE("input columns are read by name beside the states, in the model's order", "[sample_data]") {
  // The default state rule skips the input columns (here before the states).
  const std::string text = "t,w,u,x,v\n0,5,1,10,20\n0.1,6,2,11,21\n0.2,,3,12,22\n0.3,8,4,13,23\n";
  const SampleData d = SampleDataFromTables({Table(text)}, 2, {.inputs = {"u", "w"}});
  CHECK(d.state_columns == std::vector<std::string>{"x", "v"});
  CHECK(d.input_columns == std::vector<std::string>{"u", "w"});
  REQUIRE(d.u.rows() == 2);
  REQUIRE(d.u.cols() == 3);  // the row with a missing input cell is left out, as a missing state
  CHECK(d.missing_rows == 1);
  CHECK(d.u(0, 2) == 4.0);
  CHECK(d.u(1, 1) == 6.0);
  CHECK(d.y(0, 2) == 13.0);
  // Without inputs the matrix is empty (0 × K).
  CHECK(SampleDataFromTable(Table(text), 2).u.rows() == 0);
}

TEST_CASE("an input missing from the data, or also named a state, is refused by name", "[sample_data]") {
  const std::string text = "t,x,v\n0,1,2\n0.1,1,2\n0.2,1,2\n";
  CHECK_THROWS_WITH(SampleDataFromTables({Table(text, "in.csv")}, 2, {.inputs = {"u"}}),
                    "in.csv:1: no column 'u' for the model's input of that name (the columns are t,x,v)");
  CHECK_THROWS_WITH(
      SampleDataFromTables({Table(text, "in.csv")}, 2, {.columns = {"x", "v"}, .inputs = {"v"}}),
      Catch::Contains("column 'v' is the model's input 'v'; it cannot be the time or a state as well"));
  CHECK_THROWS_WITH(SampleDataFromTables({Table("t,x,v,u\n0,1,2,3\n0.1,1,2,1e200\n0.2,1,2,3\n", "in.csv")}, 2,
                                         {.inputs = {"u"}}),
                    Catch::Contains("in.csv:3: column 4 ('u'): 1e+200 is out of range"));
}

// A two-state record (x smooth with a kink at t = 3 and noise, v with a step at t = 6 and noise) as
// CSV text, with `spikes` (sample, row, size) added.
std::string KinkStepRecord(const std::vector<std::tuple<int, int, double>>& spikes) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::string text = "t,x,v\n";
  for (int k = 0; k < 1000; ++k) {
    const double t = 0.01 * k;
    double x = std::sin(t) + 2.0 * std::abs(t - 3.0) + noise(rng);  // a kink: slope −2 → +2
    double v = std::cos(t) + (t > 6.0 ? 1.0 : 0.0) + noise(rng);    // a step of 100 σ
    for (const auto& [at, row, size] : spikes) {
      if (at == k) (row == 0 ? x : v) += size;
    }
    text += fmt::format("{},{},{}\n", t, x, v);
  }
  return text;
}

TEST_CASE("an outlier off both neighbours is left out, the chain going on - noise, a kink and a step stay",
          "[sample_data]") {
  SampleData clean = SampleDataFromTable(Table(KinkStepRecord({})), 2);
  LeaveOutOutliers(&clean);
  CHECK(clean.outliers.empty());
  CHECK(clean.t.size() == 1000);
  CHECK(clean.uniform);
  // 0.15 at σ = 0.01 (the second difference's robust sd ≈ √6 σ): 2·0.15/0.0245 ≈ 12 sd; 0.08 ≈ 6.5 sd.
  SampleData d = SampleDataFromTable(
      Table(KinkStepRecord({{250, 0, 0.15}, {700, 1, -0.3}, {400, 0, 0.08}, {1, 0, 5.0}, {998, 1, 5.0}})), 2);
  LeaveOutOutliers(&d);
  REQUIRE(d.outliers.size() == 2);
  CHECK(d.outliers[0].line == 252);  // the header is line 1, sample k line k + 2
  CHECK(d.outliers[0].t == Approx(2.5));
  CHECK(d.outliers[0].row == 0);
  CHECK(d.outliers[0].sds > 10.0);
  CHECK(d.outliers[1].line == 702);
  CHECK(d.outliers[1].row == 1);
  CHECK(d.t.size() == 998);
  CHECK(d.y.cols() == 998);
  CHECK(d.line.size() == 998);
  CHECK(d.chains() == 1);
  CHECK_FALSE(d.uniform);
  CHECK(d.line[250] == 253);  // the sample after the one left out
  CHECK(d.t[250] == Approx(2.51));
  CHECK(d.y(0, 250) == clean.y(0, 251));
}

// KinkStepRecord's text with the rows of `missing` samples blank in x (the row left out on reading).
std::string WithMissing(std::string text, const std::vector<int>& missing) {
  std::vector<std::string> lines;
  std::size_t at = 0;
  for (std::size_t next; (next = text.find('\n', at)) != std::string::npos; at = next + 1)
    lines.push_back(text.substr(at, next - at));
  for (int k : missing) {
    std::string& line = lines[std::size_t(k) + 1];
    const std::size_t comma = line.find(',');
    line = line.substr(0, comma) + ",nan" + line.substr(line.find(',', comma + 1));
  }
  std::string out;
  for (const std::string& line : lines) out += line + "\n";
  return out;
}

TEST_CASE("an outlier beside a missing row and a pair of displaced neighbours are left out - a kink and a step "
          "beside missing rows stay",
          "[sample_data]") {
  // Rows missing beside the kink (t = 3), beside the step (t = 6) and elsewhere: nothing to leave out.
  const std::vector<int> missing = {100, 299, 302, 498, 599, 602, 850};
  SampleData clean = SampleDataFromTable(Table(WithMissing(KinkStepRecord({}), missing)), 2);
  REQUIRE(clean.t.size() == 1000 - missing.size());
  LeaveOutOutliers(&clean);
  CHECK(clean.outliers.empty());
  // x at sample 500 off by 0.2 (d 15 robust sd; sample 498 missing: steps 0.02, 0.01, 0.01); a pair in
  // v at 700, 701 off by 0.4 and 0.5 (d −0.3 and −0.6: 12 and 24 sd); a pair in x at 200, 201 off by
  // 0.35 each (d −0.35: 14 sd).
  SampleData d = SampleDataFromTable(
      Table(WithMissing(KinkStepRecord({{500, 0, 0.2}, {700, 1, 0.4}, {701, 1, 0.5}, {200, 0, 0.35}, {201, 0, 0.35}}),
                        missing)),
      2);
  LeaveOutOutliers(&d);
  std::vector<std::pair<long, int>> found;
  for (const OutlierSample& o : d.outliers) found.emplace_back(o.line, o.row);
  CHECK(found == std::vector<std::pair<long, int>>{{202, 0}, {203, 0}, {502, 0}, {702, 1}, {703, 1}});
  for (const OutlierSample& o : d.outliers) CHECK(o.sds > 10.0);
  // The same displacements of opposite signs in a pair: two steps, not bad frames.
  SampleData steps = SampleDataFromTable(Table(KinkStepRecord({{700, 1, 0.4}, {701, 1, -0.4}})), 2);
  LeaveOutOutliers(&steps);
  CHECK(steps.outliers.empty());
}

TEST_CASE("the outlier screen's noise level is one per state, over every chain", "[sample_data]") {
  // 40 chains of 13 samples (a gap of 1 s between them), σ = 0.01; chain 5's noise 20 times smaller,
  // and in it sample 6 displaced by 0.03 (3 σ: 2.4 robust sd of d over all chains, about 50 of
  // chain 5's own); chain 20's sample 6 by 0.15 (12 robust sd of d).
  std::mt19937_64 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::string text = "t,x\n";
  for (int c = 0; c < 40; ++c) {
    for (int k = 0; k < 13; ++k) {
      const double t = 2.0 * c + 0.01 * k;
      double x = std::sin(t) + (c == 5 ? 0.05 : 1.0) * noise(rng);
      if (k == 6 && c == 5) x += 0.03;
      if (k == 6 && c == 20) x += 0.15;
      text += fmt::format("{},{}\n", t, x);
    }
  }
  SampleData d = SampleDataFromTable(Table(text), 1);
  REQUIRE(d.chains() == 40);
  LeaveOutOutliers(&d);
  REQUIRE(d.outliers.size() == 1);
  CHECK(d.outliers[0].line == 2 + 20 * 13 + 6);
  CHECK(d.outliers[0].sds == Approx(2.0 * 0.15 / (std::sqrt(6.0) * 0.01)).epsilon(0.25));
}

}  // namespace
}  // namespace hysid

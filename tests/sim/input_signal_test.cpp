// Measured inputs: linear interpolation against its closed form, the end values, the CSV reader's
// column choice by header and its refusals by name, the range check, the interpolation's interval
// hint, the kinks the run loop stops at.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <fstream>
#include <stdexcept>
#include <string>
#include <vector>

#include "sim/input_signal.hpp"
#include "tests/testing/temp_dir.hpp"

namespace hysid {
namespace {

// u1(t) = 2 + 3t sampled at irregular times, u2(t) = t² at the same times.
InputSignal TwoInputs() {
  InputSignal s;
  s.times = {0.0, 0.1, 0.35, 0.4, 1.0};
  s.values.resize(2, 5);
  for (int k = 0; k < 5; ++k) {
    const double t = s.times[static_cast<std::size_t>(k)];
    s.values(0, k) = 2.0 + 3.0 * t;
    s.values(1, k) = t * t;
  }
  return s;
}

std::string WriteFile(const std::string& name, const std::string& text) {
  const std::filesystem::path dir = testing::FreshTempDir("input_signal_" + name);
  const std::filesystem::path p = dir / (name + ".csv");
  std::ofstream(p) << text;
  return p.string();
}

TEST_CASE("linear interpolation is exact for a linear input and the chord of a curved one", "[inputs]") {
  const InputSignal s = TwoInputs();
  for (double t : {0.0, 0.03, 0.1, 0.2, 0.349, 0.35, 0.37, 0.999, 1.0}) {
    double u[2];
    s.At(t, u);
    CHECK(u[0] == Approx(2.0 + 3.0 * t).epsilon(1e-15).margin(1e-15));
    // On [a, b] the chord of t² is (a + b)t − ab.
    std::size_t hi = 1;
    while (hi + 1 < s.times.size() && s.times[hi] <= t) ++hi;
    const double a = s.times[hi - 1], b = s.times[hi];
    CHECK(u[1] == Approx((a + b) * t - a * b).epsilon(1e-14).margin(1e-15));
  }
}

TEST_CASE("at a sample time the input is that sample - outside the range the end value", "[inputs]") {
  const InputSignal s = TwoInputs();
  double u[2];
  for (int k = 0; k < 5; ++k) {
    s.At(s.times[static_cast<std::size_t>(k)], u);
    CHECK(u[0] == s.values(0, k));
    CHECK(u[1] == s.values(1, k));
  }
  s.At(-1.0, u);
  CHECK(u[0] == s.values(0, 0));
  s.At(7.0, u);
  CHECK(u[1] == s.values(1, 4));
}

TEST_CASE("with a hint the interpolation finds the same interval from any earlier call", "[inputs]") {
  const InputSignal s = TwoInputs();
  long hint = 0;
  // Forward, backward, jumps across several intervals, the ends and beyond.
  for (double t : {0.0, 0.05, 0.1, 0.36, 0.4, 0.39, 0.11, 0.99, 1.0, 1.5, -0.2, 0.62, 0.35, 0.349}) {
    double with[2], without[2];
    s.At(t, with, &hint);
    s.At(t, without);
    CHECK(with[0] == without[0]);
    CHECK(with[1] == without[1]);
  }
}

TEST_CASE("kinks: the samples where a slope changes by more than the threshold times its median", "[inputs]") {
  InputSignal s;
  for (int k = 0; k <= 1000; ++k) s.times.push_back(0.001 * k);
  s.values.resize(3, 1001);
  for (int k = 0; k <= 1000; ++k) {
    const double t = s.times[static_cast<std::size_t>(k)];
    s.values(0, k) = std::sin(1.3 * t) + 0.5 * std::sin(3.7 * t);  // smooth, finely sampled
    s.values(1, k) = k % 2 == 0 ? 0.0 : 1.0;                        // a zig-zag
    s.values(2, k) = std::min(t, 0.25);                             // a ramp, then held
  }
  InputSignal smooth = s, zigzag = s, ramp = s;
  smooth.values = s.values.row(0);
  zigzag.values = s.values.row(1);
  ramp.values = s.values.row(2);
  // The two-tone signal's slope changes by about u''·δt = 0.003 of its median slope at most.
  CHECK(InputKinkTimes(smooth, 0.1).empty());
  CHECK(InputKinkTimes(smooth, 1e-4).size() > 900);
  const std::vector<double> every(s.times.begin() + 1, s.times.end() - 1);
  CHECK(InputKinkTimes(zigzag, 0.1) == every);
  // Median slope 0 (held for 3/4 of the samples): against the largest slope, only the corner at
  // t = 0.25 is a kink (not the rounding of the ramp's slopes).
  CHECK(InputKinkTimes(ramp, 0.1) == std::vector<double>{s.times[250]});
  // Several inputs: the union, each against its own median.
  s.values.row(1).setZero();
  CHECK(InputKinkTimes(s, 0.1) == std::vector<double>{s.times[250]});
  // Fewer than three samples have no interior sample.
  InputSignal two;
  two.times = {0.0, 1.0};
  two.values = Mat::Ones(1, 2);
  CHECK(InputKinkTimes(two, 0.0).empty());
}

TEST_CASE("the range check names the inputs and both ranges", "[inputs]") {
  const InputSignal s = TwoInputs();
  CHECK(InputRangeError(s, {"u", "w"}, 0.0, 1.0).empty());
  CHECK(InputRangeError(s, {"u", "w"}, 0.2, 0.5).empty());
  const std::string e = InputRangeError(s, {"u", "w"}, 0.0, 2.5);
  CHECK(e.find("u, w") != std::string::npos);
  CHECK(e.find("[0, 1]") != std::string::npos);
  CHECK(e.find("[0, 2.5]") != std::string::npos);
  CHECK_FALSE(InputRangeError(s, {"u"}, -0.1, 1.0).empty());
}

TEST_CASE("a built signal is checked for sizes, order and finite values", "[inputs]") {
  InputSignal s = TwoInputs();
  CHECK(InputSignalError(s, "x").empty());
  s.times[3] = 0.35;
  CHECK(InputSignalError(s, "x").find("sample 4") != std::string::npos);
  s = TwoInputs();
  s.values(1, 2) = NAN;
  CHECK(InputSignalError(s, "x").find("sample 3") != std::string::npos);
  s = TwoInputs();
  s.times.pop_back();
  CHECK(InputSignalError(s, "x").find("4 times but 5") != std::string::npos);
}

TEST_CASE("the CSV reader takes t and the inputs by header name, in the model's order", "[inputs]") {
  const std::string p = WriteFile("order", "x,w,t,u\n9,1,0,10\n9,2,0.5,11\n9,4,2,12\n");
  const InputSignal s = ReadInputSignal(p, {"u", "w"});
  REQUIRE(s.size() == 2);
  CHECK(s.times == std::vector<double>{0.0, 0.5, 2.0});
  CHECK(s.values(0, 2) == 12.0);
  CHECK(s.values(1, 1) == 2.0);
  double u[2];
  s.At(1.25, u);
  CHECK(u[0] == Approx(11.5));
  CHECK(u[1] == Approx(3.0));
}

TEST_CASE("the CSV reader refuses by name", "[inputs]") {
  auto refusal = [](const std::string& name, const std::string& text) {
    try {
      ReadInputSignal(WriteFile(name, text), {"u"});
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  CHECK(refusal("no_u", "t,v\n0,1\n1,2\n").find("no column 'u' for the model's input 'u'") !=
        std::string::npos);
  CHECK(refusal("no_t", "time,u\n0,1\n1,2\n").find("no column 't'") != std::string::npos);
  CHECK(refusal("one_row", "t,u\n0,1\n").find("1 rows") != std::string::npos);
  CHECK(refusal("missing", "t,u\n0,1\n1,\n2,3\n").find(":3: column 2 ('u'): the value is missing") !=
        std::string::npos);
  CHECK(refusal("back", "t,u\n0,1\n1,2\n1,3\n").find(":4: column 1 ('t'): 1 after 1") != std::string::npos);
  CHECK(refusal("huge", "t,u\n0,1\n1,1e200\n").find(":3: column 2 ('u'): 1e+200 is out of range") !=
        std::string::npos);
  CHECK(refusal("word", "t,u\n0,1\n1,abc\n") != "accepted");
}

}  // namespace
}  // namespace hysid

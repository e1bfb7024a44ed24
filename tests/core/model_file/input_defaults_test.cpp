// A model's default inputs: expressions of t evaluated at the sample times (against the closed form),
// and the refusals naming input_defaults.NAME.
#include <catch2/catch.hpp>

#include <cmath>

#include "core/model_file/input_defaults.hpp"

namespace hysid {
namespace {

ModelSpec TwoInputs() {
  ModelSpec s;
  s.inputs = {"u", "w"};
  s.input_defaults = {"0.5*sin(2*t) + 0.2*sin(7*t)", "t^2 - 1"};
  return s;
}

TEST_CASE("default inputs are their expressions at the sample times", "[inputs]") {
  const std::vector<double> times{0.0, 0.25, 1.0, 3.5};
  const Mat u = EvaluateInputDefaults(TwoInputs(), times);
  REQUIRE(u.rows() == 2);
  REQUIRE(u.cols() == 4);
  for (int k = 0; k < 4; ++k) {
    const double t = times[static_cast<std::size_t>(k)];
    CHECK(u(0, k) == Approx(0.5 * std::sin(2 * t) + 0.2 * std::sin(7 * t)).margin(1e-15));
    CHECK(u(1, k) == Approx(t * t - 1).margin(1e-15));
  }
  CHECK(InputsWithoutDefault(TwoInputs()).empty());
}

TEST_CASE("a missing, malformed or non-finite default is refused by its key", "[inputs]") {
  ModelSpec s = TwoInputs();
  s.input_defaults[1] = "";
  CHECK(InputsWithoutDefault(s) == "w");
  CHECK_THROWS_WITH(EvaluateInputDefaults(s, {0.0}),
                    "input_defaults.w: the model gives no default for the input 'w'");
  s.input_defaults = {"sin(", "1"};
  CHECK_THROWS_WITH(EvaluateInputDefaults(s, {0.0}), Catch::StartsWith("input_defaults.u = \"sin(\": "));
  s.input_defaults = {"1", "1/(t-2)"};
  CHECK_THROWS_WITH(EvaluateInputDefaults(s, {0.0, 1.0, 2.0}),
                    "input_defaults.w = \"1/(t-2)\" is inf at t = 2: an input must be finite");
}

}  // namespace
}  // namespace hysid

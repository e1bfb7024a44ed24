// One row of a model file's φ evaluated alone (Model::PhiRowColumns: that row's expressions, its own
// parser) against the whole φ (PhiColumns): the row's entries equal bit for bit (signed zeros too),
// for every row of a model with several identified rows, known columns, constant and expression
// entries, with and without a guard parameter (the context path), and per mode of an automaton; the
// other rows' entries are left as they were.
#include <catch2/catch.hpp>

#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>
#include <vector>

#include "core/model_file/model_file.hpp"

namespace hysid {
namespace {

// Three states, rows v and w identified, two known columns (one and c), constants in unknown
// columns, functions, comparisons, the conditional operator.
const std::string kRows = R"toml(name = "rows"
states = ["x", "v", "w"]
alpha = [{ name = "one", value = 1.0, known = true }, { name = "a", value = 2.0 },
         { name = "b", value = 0.5 }, { name = "c", value = 1.5, known = true }]
beta = [{ name = "one_b", value = 1.0, known = true }, { name = "lambda", value = 0.9 }]
[flow]
phi = [["v", 0, 0, 0],
       [0, "-x", "-v*abs(w)", "sin(x)^2"],
       ["x > 0 ? w : -w", 2.5, "min(x, v) / 3", "exp(-w^2) - 1"]]
rows = ["v", "w"]
[jump]
psi = [["x", 0], [0, "-v"], ["w", 0]]
rows = ["v"]
[[guard]]
name = "wall"
h = "x"
direction = "falling"
[sets]
C = "x >= 0"
D = "x == 0 && v <= 0"
[defaults]
x0 = [1.0, 0.0, 0.5]
t_end = 1.0
dt = 1e-3
)toml";

// The same with a guard parameter in φ and the guard: every evaluation loads the context.
std::string WithGuardParameter() {
  std::string text = kRows;
  auto replace = [&](const std::string& from, const std::string& to) {
    const auto at = text.find(from);
    REQUIRE(at != std::string::npos);
    text.replace(at, from.size(), to);
  };
  replace("[flow]", "guard_params = [{ name = \"h0\", value = 0.25 }]\n[flow]");
  replace("\"exp(-w^2) - 1\"", "\"exp(-w^2) - h0\"");
  replace("h = \"x\"", "h = \"x - h0\"");
  replace("C = \"x >= 0\"", "C = \"x >= h0\"");
  replace("D = \"x == 0 && v <= 0\"", "D = \"x == h0 && v <= 0\"");
  return text;
}

bool SameBits(double a, double b) { return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b); }

// `count` states of n entries: random, whole numbers, zeros of both signs.
std::vector<double> States(Eigen::Index n, Eigen::Index count) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-3.0, 3.0);
  std::vector<double> xs(std::size_t(n * count));
  for (std::size_t i = 0; i < xs.size(); ++i) {
    const double v = u(rng);
    xs[i] = i % 7 == 0 ? 0.0 : i % 7 == 1 ? -0.0 : i % 5 == 0 ? std::round(v) : v;
  }
  return xs;
}

// For every row r: PhiRowColumns(r) writes row r of each state's φ as PhiColumns does, bit for bit,
// and leaves the other rows' entries (a sentinel) alone. Returns how many entries were compared.
std::size_t RequireRowsAsColumns(const Model& model, const Context& ctx) {
  const Eigen::Index n = model.state_size(), m = model.alpha_size(), count = 150;
  const std::vector<double> xs = States(n, count);
  std::vector<double> full(std::size_t(n * m * count));
  model.PhiColumns(xs.data(), count, full.data(), ctx);
  constexpr double kSentinel = 12345.678;
  std::size_t compared = 0;
  for (int r = 0; r < n; ++r) {
    INFO("row " << r);
    std::vector<double> row(full.size(), kSentinel);
    model.PhiRowColumns(r, xs.data(), count, row.data(), ctx);
    for (Eigen::Index k = 0; k < count; ++k) {
      for (Eigen::Index c = 0; c < m; ++c) {
        for (Eigen::Index i = 0; i < n; ++i) {
          const std::size_t at = std::size_t(k * n * m + c * n + i);
          INFO("state " << k << ", column " << c << ", row " << i << ": " << row[at] << " vs " << full[at]);
          if (i == r) {
            REQUIRE(SameBits(row[at], full[at]));
            ++compared;
          } else {
            REQUIRE(row[at] == kSentinel);
          }
        }
      }
    }
  }
  return compared;
}

TEST_CASE("one row of φ alone equals the whole φ's row bit for bit, every row", "[model_file]") {
  const Model model = ParseModelFile(kRows, "rows.toml").model;
  REQUIRE(model.spec().flow_rows == std::vector<int>{1, 2});
  REQUIRE(RequireRowsAsColumns(model, Context{}) == 3 * 4 * 150);
  // The values are φ's: spot checks against the closed forms at one state.
  const double x[3] = {-0.0, 2.0, -0.5};
  std::vector<double> phi(12, 0.0);
  model.PhiRowColumns(2, x, 1, phi.data());
  CHECK(phi[2] == 0.5);                          // x > 0 ? w : −w at x = −0
  CHECK(phi[5] == 2.5);                          // a constant in an unknown column
  CHECK(phi[8] == -0.0 / 3.0);                   // min(x, v) / 3
  CHECK(phi[11] == std::exp(-0.25) - 1.0);       // exp(−w²) − 1
  model.PhiRowColumns(1, x, 1, phi.data());
  CHECK(SameBits(phi[4], 0.0));                  // −x at x = −0: +0
  CHECK(phi[7] == -2.0 * 0.5);
}

TEST_CASE("one row of φ alone with a guard parameter: the context's γ, as the whole φ", "[model_file]") {
  const Model model = ParseModelFile(WithGuardParameter(), "rows-gamma.toml").model;
  REQUIRE(model.gamma_size() == 1);
  REQUIRE(RequireRowsAsColumns(model, Context{}) == 3 * 4 * 150);  // the model's own h0
  const double gamma = -0.75;
  REQUIRE(RequireRowsAsColumns(model, Context{.gamma = &gamma}) == 3 * 4 * 150);
  const double x[3] = {1.0, 1.0, 0.0};
  std::vector<double> phi(12, 0.0);
  model.PhiRowColumns(2, x, 1, phi.data(), Context{.gamma = &gamma});
  CHECK(phi[11] == 1.0 + 0.75);  // exp(−w²) − h0 at w = 0
  model.PhiRowColumns(2, x, 1, phi.data());
  CHECK(phi[11] == 1.0 - 0.25);
}

// A row of expressions only (no constant entry) and a row of constants only, with the context path
// too (a guard parameter in the guard).
const std::string kNoConstants = R"toml(name = "no-constants"
states = ["x", "v"]
alpha = [{ name = "a", value = 5.0 }, { name = "b", value = 0.1 }]
beta = [{ name = "lambda", value = 0.9 }]
[flow]
phi = [[1, 0], ["-x", "-v"]]
rows = ["v"]
[jump]
psi = [["0*x"], ["-v"]]
rows = ["v"]
[[guard]]
name = "wall"
h = "x"
direction = "falling"
[sets]
C = "x >= 0"
D = "x == 0 && v <= 0"
[defaults]
x0 = [1.0, 0.0]
t_end = 1.0
dt = 1e-3
)toml";

TEST_CASE("one row of φ alone: a row without constants and a row without expressions", "[model_file]") {
  const Model model = ParseModelFile(kNoConstants, "no-constants.toml").model;
  REQUIRE(RequireRowsAsColumns(model, Context{}) == 2 * 2 * 150);
  std::string with_gamma = kNoConstants;
  with_gamma.replace(with_gamma.find("[flow]"), 6, "guard_params = [{ name = \"w\", value = 0.5 }]\n[flow]");
  with_gamma.replace(with_gamma.find("h = \"x\""), 7, "h = \"x - w\"");
  const Model contextual = ParseModelFile(with_gamma, "no-constants-gamma.toml").model;
  REQUIRE(contextual.gamma_size() == 1);
  REQUIRE(RequireRowsAsColumns(contextual, Context{}) == 2 * 2 * 150);
  const double x[2] = {2.0, -3.0};
  std::vector<double> phi(4, 0.0);
  model.PhiRowColumns(1, x, 1, phi.data());
  CHECK((phi[1] == -2.0 && phi[3] == 3.0));
  model.PhiRowColumns(0, x, 1, phi.data());
  CHECK((phi[0] == 1.0 && phi[2] == 0.0));
}

// Two modes whose φ differ (the issue's pump tank with a second state; γ in the guards).
const std::string kModes = R"toml(name = "tank"
states = ["h", "q"]
modes = ["off", "on"]
alpha = [{ name = "a", value = 0.5 }, { name = "P", value = 1.0 }, { name = "one", value = 1.0, known = true }]
guard_params = [{ name = "h_lo", value = 1.0 }, { name = "h_hi", value = 4.0 }]
[[flow]]
mode = "off"
phi = [["-sqrt(abs(h))", 0, "q*0"], [0, 0, "-q"]]
[[flow]]
mode = "on"
phi = [["-sqrt(abs(h))", 1, 0], [0, 0, "h - q"]]
[[jump]]
name = "pump-on"
guard = "low"
from = "off"
to = "on"
[[jump]]
name = "pump-off"
guard = "high"
from = "on"
to = "off"
[[guard]]
name = "low"
h = "h - h_lo"
direction = "falling"
[[guard]]
name = "high"
h = "h - h_hi"
direction = "rising"
[defaults]
x0 = [2.0, 0.0]
mode = "on"
)toml";

TEST_CASE("one row of φ alone per mode of an automaton, as the whole φ of that mode", "[model_file]") {
  const Model model = ParseModelFile(kModes, "tank.toml").model;
  REQUIRE(model.spec().modes.size() == 2);
  for (int q = 0; q < 2; ++q) {
    INFO("mode " << q);
    REQUIRE(RequireRowsAsColumns(model, Context{.mode = q}) == 2 * 3 * 150);
  }
  const double x[2] = {4.0, 1.0};
  std::vector<double> phi(6, 0.0);
  model.PhiRowColumns(1, x, 1, phi.data(), Context{.mode = 1});
  CHECK((phi[1] == 0.0 && phi[3] == 0.0 && phi[5] == 3.0));
  model.PhiRowColumns(1, x, 1, phi.data(), Context{.mode = 0});
  CHECK(phi[5] == -1.0);
}

}  // namespace
}  // namespace hysid

// A model file's φ at a sequence of (state, input, γ, t, mode) points, each a small move from the one
// before as a central difference or a sensitivity's right-hand side makes them (one state, one γ, the
// time and input, nothing, the mode, a zero's sign, a NaN): Model::Phi (which evaluates again only the
// entries that read what moved since its last call) against the whole matrix evaluated afresh
// (PhiColumns, one state at a time) bit for bit, and against φ's closed form (equal as numbers: muParser
// and C++ may differ in a zero's sign).
#include <catch2/catch.hpp>

#include <array>
#include <bit>
#include <cmath>
#include <cstdint>
#include <random>
#include <string>

#include "core/model_file/model_file.hpp"

namespace hysid {
namespace {

// Two states, an input (and so t), two guard parameters, two modes; entries reading one slot, two,
// three, none (constants), and the same slot in several entries.
const std::string kModel = R"toml(name = "memo"
states = ["x", "v"]
inputs = ["u"]
modes = ["free", "held"]
alpha = [{ name = "a", value = 1.0 }, { name = "b", value = 0.5 }, { name = "c", value = 2.0 },
         { name = "d", value = 0.1 }]
guard_params = [{ name = "g", value = 0.3 }, { name = "w", value = 1.5 }]
[[flow]]
mode = "free"
phi = [["v", 0, "x*g", 1],
       ["-x", "-v*abs(v)", "u*sin(t)", "x > w ? v - w : 0"]]
rows = ["v"]
[[flow]]
mode = "held"
phi = [[0, "g", 0, 0],
       ["-x", 2.5, "u", "w*v"]]
[[jump]]
name = "hold"
guard = "wall"
from = "free"
to = "held"
[[jump]]
name = "release"
guard = "wall"
from = "held"
to = "free"
[[guard]]
name = "wall"
h = "x - w"
direction = "rising"
[defaults]
x0 = [0.0, 1.0]
)toml";

bool SameBits(double a, double b) {
  return std::bit_cast<std::uint64_t>(a) == std::bit_cast<std::uint64_t>(b);
}

// φ's closed form (column-major, 2 × 4) at one point.
std::array<double, 8> ClosedForm(int mode, double x, double v, double u, double t, double g, double w) {
  if (mode == 0) return {v, -x, 0.0, -v * std::abs(v), x * g, u * std::sin(t), 1.0, x > w ? v - w : 0.0};
  return {0.0, -x, g, 2.5, 0.0, u, 0.0, w * v};
}

TEST_CASE("φ after a small move equals φ evaluated afresh bit for bit, and its closed form", "[model_file]") {
  const Model model = ParseModelFile(kModel, "memo.toml").model;
  REQUIRE(model.state_size() == 2);
  REQUIRE(model.alpha_size() == 4);
  std::mt19937_64 rng(5);
  std::uniform_real_distribution<double> uniform(-2.0, 2.0);
  std::uniform_int_distribution<int> kind(0, 7);
  Vec x(2);
  x << 0.5, -1.0;
  double u = 0.7, t = 0.2;
  std::array<double, 2> gamma = {0.3, 1.5};
  int mode = 0;
  std::array<int, 8> moves{};
  for (int step = 0; step < 4000; ++step) {
    const int k = step < 8 ? step : kind(rng);  // every kind of move at least once
    ++moves[std::size_t(k)];
    switch (k) {
      case 0: x[0] += 1e-6 * uniform(rng); break;           // one state, a difference's step
      case 1: x[1] = uniform(rng); break;                   // the other state
      case 2: gamma[std::size_t(step % 2)] += 1e-6; break;  // one γ
      case 3:
        t += 0.01;
        u = uniform(rng);
        break;                         // the time and the input
      case 4: break;                   // nothing (Phi after Flow)
      case 5: mode = 1 - mode; break;  // the mode
      case 6: x[0] = x[0] == 0.0 ? (std::signbit(x[0]) ? 0.0 : -0.0) : -0.0; break;  // a zero's sign
      case 7: x[1] = step % 3 == 0 ? std::nan("") : uniform(rng); break;             // a NaN
    }
    const Context ctx{.t = t, .u = &u, .gamma = gamma.data(), .mode = mode};
    Mat phi(2, 4);
    model.Phi(x, phi, ctx);
    std::array<double, 8> fresh{};
    model.PhiColumns(x.data(), 1, fresh.data(), ctx);
    const std::array<double, 8> closed = ClosedForm(mode, x[0], x[1], u, t, gamma[0], gamma[1]);
    for (std::size_t i = 0; i < 8; ++i) {
      INFO("step " << step << " (move " << k << "), mode " << mode << ", entry " << i << ": " << phi.data()[i]
                   << " vs " << fresh[i] << " afresh, " << closed[i] << " closed form");
      REQUIRE(SameBits(phi.data()[i], fresh[i]));
      REQUIRE((phi.data()[i] == closed[i] || (std::isnan(phi.data()[i]) && std::isnan(closed[i]))));
    }
  }
  for (int k = 0; k < 8; ++k) CHECK(moves[std::size_t(k)] > 300);
}

}  // namespace
}  // namespace hysid

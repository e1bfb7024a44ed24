// The covariance of a fit of several chains, where each chain's initial state is eliminated per
// chain (sim/refine/chain_sums.hpp), against the inverse of the joint Fisher information formed
// independently: each chain's run with sensitivities at the fit, FisherInformation, the (p + n·C)²
// matrix assembled and inverted whole.
#include <catch2/catch.hpp>

#include <Eigen/LU>

#include "core/builtin/impact_msd.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {
namespace {

TEST_CASE("several chains: the covariance is the joint Fisher information's inverse block", "[refine]") {
  const Model model{ImpactMsd{}};
  const Vec x0 = (Vec(2) << 20.0, 0.0).finished();
  const Trajectory truth = Simulate(model, x0, SampleGrid{6.0, 5e-4});
  const double sigma = 0.01;
  const Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, sigma), NoiseKey{.seed = 5, .stream = 0});
  std::vector<std::uint8_t> gamma(truth.j.size(), 0), chain_start(truth.j.size(), 0);
  for (std::size_t k = 1; k < truth.j.size(); ++k) gamma[k] = truth.j[k] != truth.j[k - 1];
  chain_start[4000] = chain_start[8000] = 1;  // three chains of 2 s: the first from t = 0, the others not
  const std::vector<RefineChain> chains = SplitChains(truth.t, y, chain_start, gamma);
  REQUIRE(chains.size() == 3);
  RefineOptions options;
  options.sigma = Vec::Constant(2, sigma);
  const RefineResult r = Refine(model, chains, model.alpha(), model.beta(), options);
  REQUIRE(r.ok());
  REQUIRE(r.chains_used == 3);

  const int n = 2, s = static_cast<int>(r.unknowns.size(n)) - n;
  Mat joint = Mat::Zero(s + 3 * n, s + 3 * n);
  SensitivityOptions sens;
  sens.sim.rtol = sens.sim.atol = 1e-10;
  for (std::size_t c = 0; c < chains.size(); ++c) {
    std::vector<double> times;
    std::vector<int> segments;
    for (std::size_t k = 0; k < chains[c].t.size(); ++k) {
      times.push_back(chains[c].t[k] - chains[c].t[0]);
      segments.push_back((segments.empty() ? 0 : segments.back()) +
                         (k > 0 && chains[c].gamma[k] != 0 ? 1 : 0));
    }
    const HybridParameters at{r.refined.alpha, r.refined.beta, r.chain_x0[c], r.refined.gamma};
    const SensitivityTrajectory run =
        SimulateSensitivitiesMatched(model, at, r.unknowns, times, segments, sens);
    REQUIRE(run.ok());
    const Mat f = FisherInformation(run, Vec::Constant(2, sigma));
    std::vector<Eigen::Index> place;
    for (Eigen::Index a = 0; a < s; ++a) place.push_back(a);
    for (Eigen::Index a = 0; a < n; ++a) place.push_back(s + n * static_cast<Eigen::Index>(c) + a);
    for (Eigen::Index a = 0; a < s + n; ++a) {
      for (Eigen::Index b = 0; b < s + n; ++b) joint(place[a], place[b]) += f(a, b);
    }
  }
  const Mat expected = joint.fullPivLu().inverse().topLeftCorner(s + n, s + n);
  REQUIRE(r.covariance.rows() == s + n);
  for (Eigen::Index a = 0; a < s + n; ++a) {
    for (Eigen::Index b = 0; b < s + n; ++b) {
      INFO(r.names[static_cast<std::size_t>(a)] << ", " << r.names[static_cast<std::size_t>(b)]);
      CHECK(r.covariance(a, b) ==
            Approx(expected(a, b)).epsilon(1e-4).margin(1e-6 * std::sqrt(expected(a, a) * expected(b, b))));
    }
  }
}

}  // namespace
}  // namespace hysid

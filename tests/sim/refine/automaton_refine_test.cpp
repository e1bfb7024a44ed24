// The refinement of hybrid automata: the floor/ceiling ball (two jump maps, one restitution each) from
// a perturbed start recovers e_floor and e_ceiling within 3 standard errors on seeds 1–4, with
// standard errors within 20 % of the CRLB's; the fitted model must apply the maps assigned to the
// events; and the pump tank's unknown initial mode is found by trying each candidate.
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"
#include "tests/sim/automaton_models.hpp"

namespace hysid {
namespace {

constexpr double kSigma = 1e-3;

using testing::Of;

// The truth's run, its jump labels and the maps of its jumps.
struct Truth {
  Model model;
  Vec x0;
  SampleGrid grid;
  Trajectory run;
  std::vector<std::uint8_t> labels;
  std::vector<int> maps;
  Truth(Model m, Vec start, SampleGrid g, int initial_mode = -1)
      : model(std::move(m)), x0(std::move(start)), grid(g) {
    Exogenous exo;
    exo.initial_mode = initial_mode;
    run = Simulate(model, x0, grid, {}, exo);
    labels.assign(run.j.size(), 0);
    for (std::size_t k = 1; k < run.j.size(); ++k) labels[k] = run.j[k] != run.j[k - 1];
    for (const JumpRecord& j : run.jumps) maps.push_back(j.map);
  }
  RefineChain Chain(std::uint64_t seed) const {
    const Vec sigma = Vec::Constant(model.state_size(), kSigma);
    RefineChain c = RefineChain::Uniform(AddMeasurementNoise(run.x, sigma, NoiseKey{.seed = seed, .stream = 0}),
                                         grid.dt, labels);
    c.maps = maps;
    return c;
  }
};

std::size_t IndexOf(const std::vector<std::string>& names, const std::string& name) {
  const auto it = std::find(names.begin(), names.end(), name);
  REQUIRE(it != names.end());
  return static_cast<std::size_t>(it - names.begin());
}

TEST_CASE("floor/ceiling ball: each wall's restitution within 3 SE, SEs at the CRLB", "[refine]") {
  const Truth truth(Model{testing::FloorCeiling{}}, Of({0.5, 4.0}), SampleGrid{.t_end = 2.5, .dt = 1e-3});
  REQUIRE(truth.run.status.completed());
  REQUIRE(truth.maps.size() >= 4);
  REQUIRE(truth.maps[0] == 1);
  const Unknowns unknowns = Unknowns::Of(truth.model);
  const Crlb bound = ComputeCrlb(truth.model, truth.x0, truth.grid, Vec::Constant(2, kSigma), unknowns);
  REQUIRE(bound.ok());
  const Vec alpha0 = Of({1.0, 9.81 * 1.02}), beta0 = Of({1.0, 0.75, 1.0, 0.56});
  for (std::uint64_t seed = 1; seed <= 4; ++seed) {
    const RefineResult r = Refine(truth.model, {truth.Chain(seed)}, alpha0, beta0);
    INFO("seed " << seed << ": " << ToString(r.status) << " " << r.reason);
    REQUIRE(r.ok());
    REQUIRE(r.names == bound.names);
    for (const char* name : {"e_floor", "e_ceiling", "g"}) {
      const std::size_t i = IndexOf(r.names, name);
      const Vec theta = r.estimate.Theta(r.unknowns),
                truth_theta = HybridParameters::Of(truth.model, truth.x0).Theta(r.unknowns);
      const auto e = static_cast<Eigen::Index>(i);
      INFO(name << " = " << theta[e] << " ± " << r.standard_errors[e] << ", CRLB sd " << bound.sd[e]);
      CHECK(std::abs(theta[e] - truth_theta[e]) < 3.0 * r.standard_errors[e]);
      CHECK(r.standard_errors[e] == Approx(bound.sd[e]).epsilon(0.2));
    }
  }
}

TEST_CASE("floor/ceiling ball: a fit whose maps disagree with the assigned ones is not ok", "[refine]") {
  const Truth truth(Model{testing::FloorCeiling{}}, Of({0.5, 4.0}), SampleGrid{.t_end = 2.5, .dt = 1e-3});
  RefineChain chain = truth.Chain(1);
  std::swap(chain.maps[0], chain.maps[1]);  // the ceiling's impact assigned to the floor and back
  RefineOptions options;
  options.max_span_retries = 0;
  options.routes = RefineRoutesWithout({RefineRoute::kTimeShooting});
  const RefineResult r = Refine(truth.model, {chain}, truth.model.alpha(), truth.model.beta(), options);
  CHECK(r.status == RefineStatus::kJumpCountMismatch);
  CHECK(r.reason.find("applies map 'ceiling'; the event was assigned to 'floor'") != std::string::npos);
  // The labels are a start, not a gate: multiple shooting by time follows the model's own maps.
  options.routes = AllRefineRoutes();
  const RefineResult own = Refine(truth.model, {chain}, truth.model.alpha(), truth.model.beta(), options);
  INFO(own.reason);
  REQUIRE(own.ok());
  CHECK(own.route == "multiple shooting by time");
  const Vec theta = own.estimate.Theta(own.unknowns),
            truth_theta = HybridParameters::Of(truth.model, truth.x0).Theta(own.unknowns);
  for (Eigen::Index i = 0; i < theta.size(); ++i) CHECK(std::abs(theta[i] - truth_theta[i]) < 4.0 * own.standard_errors[i]);
}

TEST_CASE("pump tank: the unknown initial mode is the candidate of best likelihood", "[refine]") {
  // Started in mode off (the model's default is on): the fit from 'on' cannot follow the first
  // samples, the fit from 'off' can.
  const Truth truth(Model{testing::PumpTank{}}, Of({1.5}), SampleGrid{.t_end = 10.0, .dt = 1e-2}, 0);
  REQUIRE(truth.run.status.completed());
  REQUIRE(truth.run.q.front() == 0);
  RefineChain chain = truth.Chain(2);
  chain.initial_mode = -1;
  const RefineResult r = Refine(truth.model, {chain}, Of({0.52, 0.97}), Vec(0));
  INFO(ToString(r.status) << " " << r.reason << " | " << r.mode_search);
  REQUIRE(r.ok());
  CHECK(r.initial_mode == 0);
  CHECK(r.estimate.initial_mode == 0);
  CHECK(r.mode_search.find("off: cost") != std::string::npos);
  const Vec theta = r.estimate.Theta(r.unknowns),
            truth_theta = HybridParameters::Of(truth.model, truth.x0).Theta(r.unknowns);
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    INFO(r.names[std::size_t(i)] << " = " << theta[i] << " ± " << r.standard_errors[i]);
    CHECK(std::abs(theta[i] - truth_theta[i]) < 4.0 * r.standard_errors[i]);
  }
}

}  // namespace
}  // namespace hysid

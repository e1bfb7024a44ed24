// A gap is a gap: missing samples inside a run keep the run one chain (the reader, the identifier's
// pass and the refinement all go on across them), so six missing samples of a 20 001-sample run cost
// what deleting them costs, and only a step longer than the maximum gap starts a new chain.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <vector>

#include "core/builtin/impact_msd.hpp"
#include "core/identify/identifier.hpp"
#include "core/io/sample_data.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

// The §5 system, 10 s at δt = 5e-4 (20 001 samples), σ = 0.05; six samples missing, spread over
// the run (one of them the sample after an impact).
struct Run {
  Model model{ImpactMsd{}};
  SampleGrid grid{10.0, 5e-4};
  Trajectory truth = Simulate(model, (Vec(2) << 20.0, 0.0).finished(), grid);
  Mat y = AddMeasurementNoise(truth.x, Vec::Constant(2, 0.05), NoiseKey{.seed = 30, .stream = 0});
  std::vector<long> missing{1500, 4000, 7777, 12000, 15500, 19000};
  Run() {
    long after_jump = 1;
    while (truth.j[static_cast<std::size_t>(after_jump)] == truth.j[static_cast<std::size_t>(after_jump - 1)]) {
      ++after_jump;
    }
    missing[1] = after_jump;
  }
  // y with the missing samples NaN.
  Mat WithNaN() const {
    Mat out = y;
    for (long k : missing) out(1, k) = std::numeric_limits<double>::quiet_NaN();
    return out;
  }
  // The run with the missing samples deleted: times and samples.
  SampleData Deleted() const {
    std::vector<double> t;
    std::vector<long> kept;
    for (long k = 0; k < y.cols(); ++k) {
      if (std::find(missing.begin(), missing.end(), k) != missing.end()) continue;
      t.push_back(truth.t[static_cast<std::size_t>(k)]);
      kept.push_back(k);
    }
    return SampleDataFromArrays({t}, {y(Eigen::all, kept)}, grid.dt);
  }
};

IdentifierSettings Settings() {
  IdentifierSettings s;
  s.detector.kind = DetectorKind::kResidual;
  s.data_rtol = s.data_atol = 1e-12;
  return s;
}

// The identifier on the data's chains and the refinement of its estimate.
RefineResult IdentifyAndRefine(const Model& model, const SampleData& d) {
  IdentifyOptions o;
  o.times = d.t;
  o.chain_start = d.chain_start;
  const IdentifyResult recursive = Identify(model, d.y, d.dt, Settings(), o);
  return RefineIdentification(model, d.t, d.y, d.chain_start, recursive);
}

void RequireSameStandardErrors(const RefineResult& r, const RefineResult& deleted, double tolerance) {
  INFO(ToString(r.status) << ": " << r.reason << " / " << ToString(deleted.status) << ": " << deleted.reason);
  REQUIRE(r.ok());
  REQUIRE(deleted.ok());
  REQUIRE(r.names == deleted.names);
  for (Eigen::Index i = 0; i < r.standard_errors.size(); ++i) {
    INFO(r.names[static_cast<std::size_t>(i)] << ": se " << r.standard_errors[i] << " against "
                                              << deleted.standard_errors[i]);
    CHECK(std::abs(r.standard_errors[i] / deleted.standard_errors[i] - 1.0) < tolerance);
  }
}

TEST_CASE("six missing samples of a 20 001-sample run: one chain, standard errors within 5 % of the "
          "run without them",
          "[refine][gap]") {
  const Run run;
  const SampleData deleted = run.Deleted();
  REQUIRE(deleted.chains() == 1);
  const RefineResult without = IdentifyAndRefine(run.model, deleted);
  CHECK(without.chains_used == 1);
  CHECK(without.samples_used == 20001 - 6);

  SECTION("read with NaN rows: the rows are dropped and the chain goes on") {
    const SampleData d = SampleDataFromArrays({{}}, {run.WithNaN()}, run.grid.dt);
    CHECK(d.missing_rows == 6);
    CHECK(d.chains() == 1);
    CHECK(d.gaps == 0);
    RequireSameStandardErrors(IdentifyAndRefine(run.model, d), without, 0.05);
  }
  SECTION("NaN columns given to Identify and the refinement as they are, on the grid") {
    const Mat y = run.WithNaN();
    const IdentifyResult recursive = Identify(run.model, y, run.grid.dt, Settings());
    CHECK(recursive.skipped_samples == 6);
    CHECK(recursive.chains == 1);
    const RefineResult r = RefineIdentification(run.model, run.truth.t, y, {}, recursive);
    CHECK(r.chains_used == 1);
    CHECK(r.samples_used == 20001 - 6);
    RequireSameStandardErrors(r, without, 0.05);
  }
}

TEST_CASE("a stretch of missing samples longer than the maximum gap starts a new chain", "[refine][gap]") {
  const Run run;
  Mat y = run.y;
  for (long k = 8000; k < 8010; ++k) y(0, k) = std::numeric_limits<double>::quiet_NaN();  // a step of 11 δt
  const SampleData d = SampleDataFromArrays({{}}, {y}, run.grid.dt);
  CHECK(d.missing_rows == 10);
  CHECK(d.gaps == 1);
  REQUIRE(d.chains() == 2);
  const RefineResult r = IdentifyAndRefine(run.model, d);
  INFO(r.reason);
  REQUIRE(r.ok());
  CHECK(r.chains_used == 2);
  CHECK(r.chain_x0.size() == 2);
  // The second chain's initial state is fitted near the true state at its first sample.
  CHECK((r.chain_x0[1] - run.truth.x.col(8010)).norm() < 0.05);
}

}  // namespace
}  // namespace hysid

// The refinement of several chains: splitting a run into chains costs information but keeps the
// estimate honest, samples at their own times, a chain whose
// detected jumps are wrong gives a status that names it, and the recoveries (the span of that chain
// cut before the disagreement, the repaired start) mend what they can.
#include <catch2/catch.hpp>

#include <cmath>
#include <string>

#include "core/builtin/impact_msd.hpp"
#include "sim/measurement.hpp"
#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

struct Run {
  Model model{ImpactMsd{}};
  Trajectory truth;
  Mat y;
  std::vector<std::uint8_t> gamma;  // the true jump samples
  Run(const Vec& x0, double sigma, std::uint64_t stream, double t_end = 10.0, double dt = 5e-4)
      : truth(Simulate(model, x0, SampleGrid{t_end, dt})) {
    y = AddMeasurementNoise(truth.x, Vec::Constant(2, sigma), NoiseKey{.seed = 11, .stream = stream});
    gamma.assign(truth.j.size(), 0);
    for (std::size_t k = 1; k < truth.j.size(); ++k) gamma[k] = truth.j[k] != truth.j[k - 1];
  }
  // Samples [from, to) as one chain.
  RefineChain Chain(long from, long to) const {
    return RefineChain::Of({truth.t.begin() + from, truth.t.begin() + to}, y.middleCols(from, to - from),
                           {gamma.begin() + from, gamma.begin() + to});
  }
};

Vec Start(const Model& m) {  // a recursive-quality start: α, β off by about 1e-3
  return (Vec(3) << m.alpha()[0], m.alpha()[1] * 1.001, m.alpha()[2] * 0.999).finished();
}

// Neither span retries nor the repaired start nor the grown span: the fit from the recursive estimate and its checks.
RefineOptions NoRecovery() {
  RefineOptions o;
  o.max_span_retries = 0;
  o.routes = RefineRoutesWithout({RefineRoute::kRepairedStart, RefineRoute::kGrownSpan, RefineRoute::kTimeShooting});
  return o;
}

// Each shared unknown (α, β) within k of its standard errors of the truth.
void RequireNearTruth(const Model& model, const RefineResult& r, double k) {
  const Unknowns shared = Unknowns::Of(model, /*with_x0=*/false);
  const Vec e = r.estimate.Theta(shared) - HybridParameters::Of(model, Vec::Zero(2)).Theta(shared);
  for (Eigen::Index i = 0; i < e.size(); ++i) {
    INFO(r.names[static_cast<std::size_t>(i)] << ": error " << e[i] << ", se " << r.standard_errors[i]);
    CHECK(std::abs(e[i]) < k * r.standard_errors[i]);
  }
}

TEST_CASE("three runs, one cut in two: joint α, β within 4 se, the cut costs information",
          "[refine][chains]") {
  const Run a((Vec(2) << 20.0, 0.0).finished(), 0.05, 1), b((Vec(2) << 15.0, 5.0).finished(), 0.05, 2),
      c((Vec(2) << 10.0, -10.0).finished(), 0.05, 3);
  const Vec alpha0 = Start(a.model), beta0 = a.model.beta();
  const long half = a.truth.size() / 2;
  const RefineResult whole = Refine(
      a.model, {a.Chain(0, a.truth.size()), b.Chain(0, b.truth.size()), c.Chain(0, c.truth.size())}, alpha0,
      beta0);
  const RefineResult cut = Refine(a.model,
                                        {a.Chain(0, half), a.Chain(half + 1, a.truth.size()),
                                         b.Chain(0, b.truth.size()), c.Chain(0, c.truth.size())},
                                        alpha0, beta0);
  INFO(whole.reason << " / " << cut.reason);
  REQUIRE(whole.ok());
  REQUIRE(cut.ok());
  CHECK(cut.chains_used == 4);
  CHECK(cut.chain_x0.size() == 4);
  // α, β and the first chain's initial state (run a's, in both).
  const Vec truth = HybridParameters::Of(a.model, a.truth.x.col(0)).Theta(whole.unknowns);
  for (const RefineResult* r : {&whole, &cut}) {
    const Vec e = r->estimate.Theta(r->unknowns) - truth;
    for (Eigen::Index i = 0; i < e.size(); ++i) CHECK(std::abs(e[i]) < 4 * r->standard_errors[i]);
  }
  for (Eigen::Index i = 0; i < truth.size(); ++i) CHECK(cut.standard_errors[i] >= whole.standard_errors[i]);
  // The second chain of the cut run starts at its own first sample, fitted near the true state there.
  CHECK((cut.chain_x0[1] - a.truth.x.col(half + 1)).norm() < 0.05);
}

TEST_CASE("samples at their own times: the model is read at each sample's time", "[refine][chains]") {
  // Every other sample of a run on a grid of 2.5e-4: steps of 2.5e-4 and 7.5e-4 alternate.
  const Run fine((Vec(2) << 20.0, 0.0).finished(), 0.05, 4, 10.0, 2.5e-4);
  std::vector<double> t;
  std::vector<std::uint8_t> gamma;
  for (long k = 0; k < fine.truth.size(); ++k) {
    if (k % 4 == 1 || k % 4 == 2) continue;  // keep samples 0, 3, 4, 7, 8, ...
    const auto u = static_cast<std::size_t>(k);
    t.push_back(fine.truth.t[u]);
    gamma.push_back(0);
  }
  Mat y(2, static_cast<Eigen::Index>(t.size()));
  long i = 0;
  int j_prev = 0;
  for (long k = 0; k < fine.truth.size(); ++k) {
    if (k % 4 == 1 || k % 4 == 2) continue;
    y.col(i) = fine.y.col(k);
    const int j = fine.truth.j[static_cast<std::size_t>(k)];
    gamma[static_cast<std::size_t>(i)] = i > 0 && j != j_prev;
    j_prev = j;
    ++i;
  }
  const RefineChain irregular = RefineChain::Of(std::move(t), std::move(y), std::move(gamma));
  const RefineResult r = Refine(fine.model, {irregular}, Start(fine.model), fine.model.beta());
  INFO(r.reason);
  REQUIRE(r.ok());
  const Vec e =
      r.estimate.Theta(r.unknowns) - HybridParameters::Of(fine.model, fine.truth.x.col(0)).Theta(r.unknowns);
  for (Eigen::Index k = 0; k < e.size(); ++k) CHECK(std::abs(e[k]) < 4 * r.standard_errors[k]);
  CHECK(r.normalized_rms == Approx(1.0).margin(0.05));
}

TEST_CASE("without recoveries, a chain with a missed jump, or too short to fit: a status, never a silent ok",
          "[refine][chains]") {
  const Run a((Vec(2) << 20.0, 0.0).finished(), 0.05, 5), b((Vec(2) << 15.0, 5.0).finished(), 0.05, 6);
  RefineChain wrong = b.Chain(0, b.truth.size());
  std::size_t k = 1;
  while (wrong.gamma[k] == 0) ++k;
  wrong.gamma[k] = 0;  // the detector "missed" the first jump of chain 2
  const RefineResult r = Refine(a.model, {a.Chain(0, a.truth.size()), wrong}, Start(a.model),
                                      a.model.beta(), NoRecovery());
  INFO(r.reason);
  CHECK_FALSE(r.ok());  // measured: not-converged (the matched flow continues past the missed jump)
  CHECK_FALSE(r.reason.empty());
  CHECK(r.standard_errors.size() == 0);
  CHECK(r.estimate.alpha == r.start.alpha);
  // A spurious detected jump near the end of chain 2: the model never reaches that many segments.
  RefineChain extra = b.Chain(0, b.truth.size());
  extra.gamma[extra.gamma.size() - 20] = 1;
  const RefineResult s = Refine(a.model, {a.Chain(0, a.truth.size()), extra}, Start(a.model),
                                      a.model.beta(), NoRecovery());
  CHECK(s.status == RefineStatus::kStartFailed);
  CHECK_THAT(s.reason, Catch::Contains("chain 2"));
  // Chains of fewer than 2n + 2 samples are left out and counted; none left: too few samples.
  const RefineResult tiny =
      Refine(a.model, {a.Chain(0, 5), a.Chain(10, 15)}, Start(a.model), a.model.beta());
  CHECK(tiny.status == RefineStatus::kTooFewSamples);
  CHECK(tiny.chains_skipped == 2);
  CHECK_THAT(tiny.chain_span_reason[0], Catch::Contains("left out: 5 samples"));
  const RefineResult empty =
      Refine(a.model, {a.Chain(0, 0), a.Chain(10, 15)}, Start(a.model), a.model.beta());
  CHECK(empty.status == RefineStatus::kTooFewSamples);
  CHECK(empty.chain_samples_used == std::vector<long>{0, 0});
}

// Two runs of 10 s; the second one ends `tail` samples after its last jump.
struct TwoRuns {
  Run a{(Vec(2) << 20.0, 0.0).finished(), 0.05, 7}, b{(Vec(2) << 15.0, 5.0).finished(), 0.05, 8};
  long last = 0;  // b's last jump
  RefineChain second;
  explicit TwoRuns(long tail) {
    for (long k = 1; k < b.truth.size(); ++k) last = b.gamma[static_cast<std::size_t>(k)] ? k : last;
    second = b.Chain(0, std::min(last + tail, b.truth.size()));
  }
  RefineResult Fit(const RefineOptions& options = {}) const {
    return Refine(a.model, {a.Chain(0, a.truth.size()), second}, Start(a.model), a.model.beta(),
                        options);
  }
};

TEST_CASE("a chain whose detector missed its last jump, near its end: that chain's span is cut before it",
          "[refine][chains]") {
  // Too close to the end for the repaired start to add the jump; the fit distorted by the missed
  // jump puts its own jump too far from the true one for the fit mended from it to pass its checks.
  TwoRuns runs(30);
  runs.second.gamma[static_cast<std::size_t>(runs.last)] = 0;
  const RefineResult kept = runs.Fit(NoRecovery());
  INFO(ToString(kept.status) << ": " << kept.reason);
  CHECK(kept.status == RefineStatus::kJumpCountMismatch);
  CHECK_THAT(kept.reason, Catch::Contains("chain 2"));
  CHECK(kept.standard_errors.size() == 0);
  CHECK(kept.estimate.alpha == kept.start.alpha);
  // The labelled routes alone cut the span.
  RefineOptions labelled;
  labelled.routes = RefineRoutesWithout({RefineRoute::kTimeShooting});
  const RefineResult r = runs.Fit(labelled);
  INFO(ToString(r.status) << ": " << r.reason << " | " << r.span_reason << " | " << r.start_repair);
  REQUIRE(r.ok());
  CHECK(r.start_repair.empty());
  CHECK(r.mended.empty());
  CHECK(r.chain_samples_used[0] == runs.a.truth.size());
  CHECK(r.chain_span_reason[0].empty());
  // Chain 2 ends the margin (ceil(jump_time_tolerance) + 2 samples) before the missed jump.
  CHECK(r.chain_samples_used[1] == runs.last - 5);
  CHECK(r.samples_used == runs.a.truth.size() + runs.last - 5);
  CHECK_THAT(r.chain_span_reason[1], Catch::Contains("ended in jump-count-mismatch"));
  CHECK_THAT(r.chain_span_reason[1], Catch::Contains("disagree from sample " + std::to_string(runs.last)));
  CHECK_THAT(r.span_reason, Catch::StartsWith("chain 2: "));
  CHECK(r.model_jumps == r.detected_jumps);
  RequireNearTruth(runs.a.model, r, 4.0);
  // Every route: the fit by time (the model's own events) is ok on every sample of both chains, each
  // standard error at most the cut span's, so it is kept.
  const RefineResult all = runs.Fit();
  INFO(ToString(all.status) << ": " << all.reason);
  REQUIRE(all.ok());
  CHECK(all.route == "multiple shooting by time");
  CHECK(all.samples_used == runs.a.truth.size() + static_cast<long>(runs.second.t.size()));
  CHECK(all.chain_span_reason == std::vector<std::string>(2));
  const auto shared = static_cast<Eigen::Index>(r.unknowns.shared());
  CHECK((all.standard_errors.head(shared).array() <= r.standard_errors.head(shared).array()).all());
  RequireNearTruth(runs.a.model, all, 4.0);
}

TEST_CASE("a chain whose detector missed its first jump: the span cannot help - the repaired start adds it",
          "[refine][chains]") {
  TwoRuns runs(1000);
  std::size_t k = 1;
  while (runs.second.gamma[k] == 0) ++k;
  runs.second.gamma[k] = 0;
  RefineOptions retries_only;
  retries_only.routes = RefineRoutesWithout({RefineRoute::kRepairedStart, RefineRoute::kGrownSpan, RefineRoute::kTimeShooting});
  for (const RefineOptions& o : {NoRecovery(), retries_only}) {
    const RefineResult kept = runs.Fit(o);
    INFO(ToString(kept.status) << ": " << kept.reason);
    CHECK_FALSE(kept.ok());
    CHECK_FALSE(kept.reason.empty());
    CHECK(kept.standard_errors.size() == 0);
  }
  const RefineResult r = runs.Fit();
  INFO(ToString(r.status) << ": " << r.reason << " | " << r.start_repair);
  REQUIRE(r.ok());
  CHECK_THAT(r.start_repair, Catch::Contains("0 dropped, 0 moved, 1 added"));
  CHECK_THAT(r.start_repair, Catch::Contains("changed in chain 2"));
  CHECK(r.samples_used == runs.a.truth.size() + runs.second.y.cols());
  CHECK(r.span_reason.empty());
  CHECK(r.model_jumps == r.detected_jumps);
  CHECK(r.start.beta == runs.a.model.beta());  // the start reported is the caller's
  RequireNearTruth(runs.a.model, r, 4.0);
}

TEST_CASE("a spurious detection near a chain's end: the retries fit less, the repaired start drops it",
          "[refine][chains]") {
  TwoRuns runs(1000);
  const std::size_t spurious = runs.second.gamma.size() - 20;
  runs.second.gamma[spurious] = 1;
  CHECK(runs.Fit(NoRecovery()).status == RefineStatus::kStartFailed);
  RefineOptions retries_only;
  retries_only.routes = RefineRoutesWithout({RefineRoute::kRepairedStart, RefineRoute::kGrownSpan});
  const RefineResult cut = runs.Fit(retries_only);
  INFO(ToString(cut.status) << ": " << cut.reason << " | " << cut.span_reason);
  REQUIRE(cut.ok());
  CHECK(cut.chain_samples_used[1] < static_cast<long>(spurious));
  CHECK_THAT(cut.chain_span_reason[1], Catch::Contains("ended in start-failed"));
  const RefineResult r = runs.Fit();
  INFO(ToString(r.status) << ": " << r.reason << " | " << r.start_repair);
  REQUIRE(r.ok());
  CHECK_THAT(r.start_repair, Catch::Contains("1 dropped, 0 moved, 0 added"));
  CHECK(r.chain_samples_used[1] == runs.second.y.cols());
  RequireNearTruth(runs.a.model, r, 4.0);
}

}  // namespace
}  // namespace hysid

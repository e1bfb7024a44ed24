// Every estimator of the factory (PluginNames<EstimatorKind>()) on degenerate data: finite estimates always,
// and the errors-in-variables estimators say so in their status. RLS counts rows with φ ≠ 0 towards
// excitation, so its status is not checked here (see tests/core/estimators/rls_test.cpp).
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>
#include <string>

#include "core/estimators/estimator.hpp"
#include "tests/testing/eiv_problem.hpp"
#include "tests/testing/plugin_list.hpp"

namespace hysid {
namespace {

void CheckFinite(const Estimator& e) {
  CHECK(e.estimate().allFinite());
  if (const auto cov = e.covariance_matrix()) CHECK(cov->allFinite());
}

TEST_CASE("a kind's descriptor is the one at its place in the list: names and classes agree", "[estimator]") {
  testing::CheckPluginList<EstimatorKind>({{EstimatorKind::kRls, "rls"},
                                           {EstimatorKind::kGtls, "gtls"},
                                           {EstimatorKind::kFrisch, "frisch"},
                                           {EstimatorKind::kIntegral, "integral"}},
                                          [](EstimatorKind kind) {
                                            EstimatorSettings s;
                                            s.kind = kind;
                                            return MakeEstimator(s, Vec::Zero(2));
                                          });
}

TEST_CASE("every estimator by name: degenerate data gives finite estimates and a status",
          "[estimator][eiv]") {
  const testing::EivData d = testing::MakeEivData(Vec::Ones(3), Vec::Constant(3, 0.2), 0.2, 300, 8, 0);
  for (const std::string& name : PluginNames<EstimatorKind>()) {
    INFO("estimator " << name);
    EstimatorSettings s;
    s.kind = ParseKind<EstimatorKind>(name);
    s.window = 20;
    const bool eiv = name != "rls";
    SECTION("no excitation, with forgetting: " + name) {
      s.forgetting = 0.95;
      auto e = MakeEstimator(s, Vec::Zero(3));
      for (int k = 0; k < 2000; ++k) e->Update(Mat::Zero(1, 3), Vec::Zero(1));
      CheckFinite(*e);
      CHECK(e->status() == EstimatorStatus::kNotExcited);
    }
    SECTION("repeated rows: " + name) {
      auto e = MakeEstimator(s, Vec::Zero(3));
      for (int k = 0; k < 300; ++k) e->Update(d.phi.topRows(1), d.y.head(1));
      CheckFinite(*e);
      if (eiv) CHECK(e->status() != EstimatorStatus::kOk);
    }
    SECTION("a zero column: " + name) {
      Mat phi = d.phi;
      phi.col(2).setZero();
      auto e = MakeEstimator(s, Vec::Zero(3));
      for (long k = 0; k < phi.rows(); ++k) e->Update(phi.middleRows(k, 1), d.y.segment(k, 1));
      CheckFinite(*e);
      if (eiv) CHECK(e->status() != EstimatorStatus::kOk);
    }
    SECTION("two identical columns: " + name) {
      Mat phi = d.phi;
      phi.col(1) = phi.col(0);
      auto e = MakeEstimator(s, Vec::Zero(3));
      for (long k = 0; k < phi.rows(); ++k) e->Update(phi.middleRows(k, 1), d.y.segment(k, 1));
      CheckFinite(*e);
      if (eiv) CHECK(e->status() != EstimatorStatus::kOk);
    }
    SECTION("non-finite rows are skipped and counted: " + name) {
      auto e = MakeEstimator(s, Vec::Zero(3));
      for (long k = 0; k < 100; ++k) e->Update(d.phi.middleRows(k, 1), d.y.segment(k, 1));
      Mat bad = d.phi.topRows(1);
      bad(0, 1) = std::nan("");
      e->Update(bad, d.y.head(1));
      e->Update(d.phi.topRows(1), Vec::Constant(1, INFINITY));
      CHECK(e->skipped() == 2);
      CheckFinite(*e);
      CHECK(e->status() == EstimatorStatus::kOk);
    }
  }
}

}  // namespace
}  // namespace hysid

namespace hysid {
namespace {

TEST_CASE("every estimator by name: a clone goes on as the original, bit for bit", "[estimator]") {
  const testing::EivData d = testing::MakeEivData(Vec::Ones(3), Vec::Constant(3, 0.2), 0.2, 600, 9, 0);
  for (const std::string& name : PluginNames<EstimatorKind>()) {
    INFO("estimator " << name);
    EstimatorSettings s;
    s.kind = ParseKind<EstimatorKind>(name);
    s.window = 50;
    s.refactor_every = 100;
    if (s.NeedsNoiseShape()) s.noise_shape = Mat::Identity(4, 4);
    auto original = MakeEstimator(s, Vec::Zero(3));
    for (long k = 0; k < 300; ++k) original->Update(d.phi.middleRows(k, 1), d.y.segment(k, 1));
    const std::unique_ptr<Estimator> clone = original->Clone();
    for (long k = 300; k < d.phi.rows(); ++k) {
      original->Update(d.phi.middleRows(k, 1), d.y.segment(k, 1));
      clone->Update(d.phi.middleRows(k, 1), d.y.segment(k, 1));
    }
    CHECK(clone->name() == original->name());
    CHECK(clone->estimate() == original->estimate());
    CHECK(clone->updates() == original->updates());
    CHECK(clone->status() == original->status());
    CHECK(clone->solution_box() == original->solution_box());
    const Mat* a = original->covariance_matrix();
    const Mat* b = clone->covariance_matrix();
    REQUIRE((a == nullptr) == (b == nullptr));
    if (a != nullptr) CHECK(*a == *b);
    original->Update(d.phi.topRows(1), d.y.head(1));  // the clone does not share the original's state
    CHECK(clone->updates() + 1 == original->updates());
  }
}

}  // namespace
}  // namespace hysid

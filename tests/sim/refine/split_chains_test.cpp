// The chains of SplitChains: a chain with no sample missing views its columns of the caller's y and u
// (no copy), one with a missing sample holds a compacted copy of its own; either way a chain reads
// the samples of its run in order, and copies and assignments of chains keep reading the right ones.
#include <catch2/catch.hpp>

#include <cmath>
#include <limits>
#include <stdexcept>

#include "sim/refine/refine.hpp"

namespace hysid {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// 12 samples of 2 states and 1 input, sample k holding (k, 100 + k) and input 200 + k, at t = 0.1 k;
// chains start at samples 0, 4 and 8; a jump labelled at every third sample.
struct Samples {
  std::vector<double> t;
  Mat y{2, 12}, u{1, 12};
  std::vector<std::uint8_t> chain_start = std::vector<std::uint8_t>(12, 0), gamma = std::vector<std::uint8_t>(12, 0);
  Samples() {
    for (int k = 0; k < 12; ++k) {
      t.push_back(0.1 * k);
      y(0, k) = k;
      y(1, k) = 100 + k;
      u(0, k) = 200 + k;
      gamma[static_cast<std::size_t>(k)] = k % 3 == 0 ? 1 : 0;
    }
    chain_start[4] = chain_start[8] = 1;
  }
};

// Chain c holds exactly samples `ks` of s, in order.
void RequireSamples(const RefineChain& c, const Samples& s, const std::vector<int>& ks) {
  REQUIRE(c.y.rows() == 2);
  REQUIRE(c.y.cols() == std::ssize(ks));
  REQUIRE(c.u.cols() == std::ssize(ks));
  REQUIRE(c.t.size() == ks.size());
  REQUIRE(c.gamma.size() == ks.size());
  for (std::size_t i = 0; i < ks.size(); ++i) {
    const int k = ks[i];
    const auto col = static_cast<Eigen::Index>(i);
    CHECK(c.t[i] == s.t[static_cast<std::size_t>(k)]);
    CHECK(c.y(0, col) == k);
    CHECK(c.y(1, col) == 100 + k);
    CHECK(c.u(0, col) == 200 + k);
    CHECK(c.gamma[i] == s.gamma[static_cast<std::size_t>(k)]);
  }
}

TEST_CASE("SplitChains: a chain without missing samples views the caller's columns", "[refine][chains]") {
  const Samples s;
  const std::vector<RefineChain> chains = SplitChains(s.t, s.y, s.chain_start, s.gamma, s.u);
  REQUIRE(chains.size() == 3);
  for (int c = 0; c < 3; ++c) {
    RequireSamples(chains[std::size_t(c)], s, {4 * c, 4 * c + 1, 4 * c + 2, 4 * c + 3});
    CHECK(chains[std::size_t(c)].y.data() == s.y.data() + 2 * 4 * c);  // no copy
    CHECK(chains[std::size_t(c)].u.data() == s.u.data() + 4 * c);
    CHECK(chains[std::size_t(c)].owned == nullptr);
  }
  const std::vector<RefineChain> one = SplitChains(s.t, s.y, {}, s.gamma);
  REQUIRE(one.size() == 1);
  CHECK(one[0].y.data() == s.y.data());
  CHECK(one[0].y.cols() == 12);
  CHECK(one[0].u.rows() == 0);
}

TEST_CASE("SplitChains: a chain with a missing sample holds a compacted copy", "[refine][chains]") {
  Samples s;
  s.y(1, 5) = kNaN;  // sample 5 missing: chain 2 goes on across it
  s.y(0, 8) = s.y(0, 9) = s.y(0, 10) = s.y(0, 11) = std::numeric_limits<double>::infinity();  // chain 3 all missing
  const std::vector<RefineChain> chains = SplitChains(s.t, s.y, s.chain_start, s.gamma, s.u);
  REQUIRE(chains.size() == 2);
  RequireSamples(chains[0], s, {0, 1, 2, 3});
  CHECK(chains[0].owned == nullptr);
  RequireSamples(chains[1], s, {4, 6, 7});
  REQUIRE(chains[1].owned != nullptr);
  CHECK(chains[1].y.data() == chains[1].owned->y.data());
}

TEST_CASE("RefineChain copies and assignments keep reading their own samples", "[refine][chains]") {
  Samples s;
  s.y(0, 1) = kNaN;
  std::vector<RefineChain> chains = SplitChains(s.t, s.y, s.chain_start, s.gamma, s.u);
  REQUIRE(chains.size() == 3);
  RefineChain copy = chains[0];  // holds a copy of samples 0, 2, 3
  chains.clear();                // the copy shares that storage: still there
  RequireSamples(copy, s, {0, 2, 3});
  const std::vector<RefineChain> again = SplitChains(s.t, s.y, s.chain_start, s.gamma, s.u);
  copy = again[2];  // a view rebinds: nothing of `again[0]`'s samples or of s is written
  RequireSamples(copy, s, {8, 9, 10, 11});
  CHECK(copy.y.data() == again[2].y.data());
  RequireSamples(again[0], s, {0, 2, 3});
  CHECK(s.y(0, 8) == 8.0);
  const RefineChain uniform = RefineChain::Uniform(s.y.leftCols(3), 0.5, {0, 0, 1});
  CHECK(uniform.t == std::vector<double>{0.0, 0.5, 1.0});
  CHECK(uniform.y(1, 2) == 102.0);
  CHECK(uniform.u.rows() == 0);
}

TEST_CASE("SplitChains: sizes that disagree are refused", "[refine][chains]") {
  const Samples s;
  std::vector<std::uint8_t> short_gamma(s.gamma.begin(), s.gamma.end() - 1);
  CHECK_THROWS_AS(SplitChains(s.t, s.y, s.chain_start, short_gamma), std::invalid_argument);
  CHECK_THROWS_AS(SplitChains(s.t, s.y, std::vector<std::uint8_t>(3, 0), s.gamma), std::invalid_argument);
  const Mat short_u = s.u.leftCols(5);
  CHECK_THROWS_AS(SplitChains(s.t, s.y, s.chain_start, s.gamma, short_u), std::invalid_argument);
}

}  // namespace
}  // namespace hysid

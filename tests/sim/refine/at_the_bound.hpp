// A fit at the Cramér–Rao bound, as the refinement tests require it.
#pragma once

#include <catch2/catch.hpp>

#include <cmath>

#include "sim/refine/refine.hpp"
#include "sim/sensitivity/crlb.hpp"

namespace hysid {

// Every unknown within 4 of its reported standard errors of the truth, and each standard error within
// 25 % of the bound's sd.
inline void RequireAtTheBound(const RefineResult& r, const Vec& truth, const Crlb& bound) {
  INFO(ToString(r.status) << ": " << r.reason << "; at " << r.refined.Theta(r.unknowns).transpose());
  REQUIRE(r.ok());
  REQUIRE(bound.ok());
  const Vec theta = r.estimate.Theta(r.unknowns);
  for (Eigen::Index i = 0; i < theta.size(); ++i) {
    INFO(r.names[std::size_t(i)] << " = " << theta[i] << " ± " << r.standard_errors[i] << ", truth " << truth[i]
                                  << ", CRLB sd " << bound.sd[i]);
    CHECK(std::abs(theta[i] - truth[i]) < 4 * r.standard_errors[i]);
    CHECK(r.standard_errors[i] == Approx(bound.sd[i]).epsilon(0.25));
  }
}

}  // namespace hysid

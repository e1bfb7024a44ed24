// A static errors-in-variables problem with known truth, shared by the gtls and frisch tests.
//   x ~ N(0, I_p) (true regressors), y₀ = xᵀθ,  observed φ = x + diag(σ_φ) e,  y = y₀ + σ_y e'.
// Every draw comes from hysid::StandardNormals(NoiseKey{seed, run}, kMeasurementNoise, row, block),
// so a run is reproducible from (seed, run) alone.
#pragma once

#include <cstdint>

#include "core/model/model.hpp"
#include "sim/measurement.hpp"

namespace hysid::testing {

struct EivData {
  Mat phi;  // rows × p, observed
  Vec y;    // rows, observed
};

inline EivData MakeEivData(const Vec& theta, const Vec& sigma_phi, double sigma_y, long rows,
                           std::uint64_t seed, std::uint64_t run) {
  const Eigen::Index p = theta.size();
  EivData d{Mat(rows, p), Vec(rows)};
  // Normals needed per row: p (x) + p (φ noise) + 1 (y noise), four per block.
  const Eigen::Index need = 2 * p + 1;
  Vec draws(((need + 3) / 4) * 4);
  for (long r = 0; r < rows; ++r) {
    for (Eigen::Index b = 0; b < draws.size() / 4; ++b) {
      const Normal4 n = StandardNormals(NoiseKey{seed, run}, RandomPurpose::kMeasurementNoise,
                                        static_cast<std::uint64_t>(r), static_cast<std::uint64_t>(b));
      for (int i = 0; i < 4; ++i) draws[4 * b + i] = n.v[i];
    }
    double y0 = 0.0;
    for (Eigen::Index i = 0; i < p; ++i) {
      y0 += draws[i] * theta[i];
      d.phi(r, i) = draws[i] + sigma_phi[i] * draws[p + i];
    }
    d.y[r] = y0 + sigma_y * draws[2 * p];
  }
  return d;
}

}  // namespace hysid::testing

// Noisy measurements y_k = ξ(t_k) + e_k, e_k ~ N(0, diag(σ²)).
//
// The noise comes from Random123's Philox4x64 (a counter-based generator): the key is
// (seed, stream) and the counter is (sample index, purpose, block), so a sample's noise depends only
// on those numbers — never on which thread draws it or in what order.
#pragma once

#include <cstdint>

#include "core/model/model.hpp"

namespace hysid {

struct NoiseKey {
  std::uint64_t seed = 1;    // the run's (master) seed
  std::uint64_t stream = 0;  // trial index (or any id unique within the seed)
};

// Purposes keep independent draws of one (seed, stream) apart.
enum class RandomPurpose : std::uint64_t { kMeasurementNoise = 0, kInitialState = 1 };

// Four independent standard normals for (key, purpose, counter, block).
struct Normal4 {
  double v[4];
};
Normal4 StandardNormals(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter,
                        std::uint64_t block = 0);

// Four independent uniforms in (0, 1).
struct Uniform4 {
  double v[4];
};
Uniform4 Uniforms(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter,
                  std::uint64_t block = 0);

// y = x + diag(σ) e column by column; `sigma` has one entry per state (row of x), each ≥ 0.
// Column k uses counter k. Throws std::invalid_argument for a wrong size or a negative σ.
Mat AddMeasurementNoise(const Mat& x, const Vec& sigma, const NoiseKey& key);

}  // namespace hysid

// Noisy measurements y_k = ξ(t_k) + e_k, e_k ~ N(0, diag(σ²)).
//
// The noise comes from Random123's Philox4x64-10 (a counter-based generator): the key is
// (seed, stream) and the counter holds a block index, a purpose and two further key words (`sub`), so
// a draw depends only on those numbers — never on which thread draws it or in what order.
//
// Streams of normals (FillStandardNormals, AddMeasurementNoise): normal number m of the stream named
// by `key` is output word m mod 4 of the Philox block ⌊m/4⌋ (counter (⌊m/4⌋, kNoiseStream, sub[0],
// sub[1])), turned into a normal by a 256-layer ziggurat. The ~1 % of words that the ziggurat rejects
// continue with draws keyed by m itself (counter (m, kNoiseStreamRetry + 256·attempt, sub[0],
// sub[1])), so normal m depends only on (key, m).
#pragma once

#include <cstddef>
#include <cstdint>

#include "core/model/model.hpp"

namespace hysid {

struct NoiseKey {
  std::uint64_t seed = 1;    // the run's (master) seed
  std::uint64_t stream = 0;  // trial index (or any id unique within the seed)
  // Two more words in the counter of a stream (sweeps: the model's index and δt's bit pattern).
  std::uint64_t sub[2] = {0, 0};
};

// Purposes keep independent draws of one (seed, stream) apart.
enum class RandomPurpose : std::uint64_t {
  kMeasurementNoise = 0,  // StandardNormals and AddMeasurementNoisePerSample
  kInitialState = 1,      // Uniforms for drawn initial states
  kNoiseStream = 2,       // FillStandardNormals: one block of four normals per counter
  kNoiseStreamRetry = 3,  // FillStandardNormals: the ziggurat's rejected words (+ 256·attempt)
};

// Four independent standard normals for (key, purpose, counter, block): Box–Muller on the four
// outputs of one Philox call with counter (counter, purpose, block, 0). `key.sub` is not used.
struct Normal4 {
  double v[4];
};
Normal4 StandardNormals(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter,
                        std::uint64_t block = 0);

// Four independent uniforms in (0, 1), counter as StandardNormals.
struct Uniform4 {
  double v[4];
};
Uniform4 Uniforms(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter, std::uint64_t block = 0);

// out[j] = normal number first + j of the stream `key`, j < count (see the top of this file).
void FillStandardNormals(const NoiseKey& key, std::uint64_t first, double* out, std::size_t count);

// y = x + diag(σ) E, E(i, k) = normal number k·n + i of the stream `key` (n = x.rows()); `sigma` has
// one entry per state, each ≥ 0. Throws std::invalid_argument for a wrong size or a negative σ.
Mat AddMeasurementNoise(const Mat& x, const Vec& sigma, const NoiseKey& key);

// The earlier draw, kept because `hysid reproduce paper` and hysid_eiv_study's committed results were
// made with it: sample k uses the Philox call with counter (k, kMeasurementNoise, block, 0) for
// components 4·block … 4·block + 3, Box–Muller on its outputs in pairs (a pair only when a component
// needs it). About 5× slower per sample than AddMeasurementNoise for n = 2. Same checks.
Mat AddMeasurementNoisePerSample(const Mat& x, const Vec& sigma, const NoiseKey& key);

}  // namespace hysid

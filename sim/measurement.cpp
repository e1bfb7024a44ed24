#include "sim/measurement.hpp"

#include <array>
#include <cmath>
#include <stdexcept>

#include <Random123/boxmuller.hpp>
#include <Random123/philox.h>
#include <Random123/uniform.hpp>
#include <fmt/format.h>

namespace hysid {
namespace {

using Block = r123::Philox4x64::ctr_type;

Block Philox(const NoiseKey& key, std::uint64_t c0, std::uint64_t c1, std::uint64_t c2, std::uint64_t c3) {
  const r123::Philox4x64 generator;
  const r123::Philox4x64::key_type k = {{key.seed, key.stream}};
  return generator(Block{{c0, c1, c2, c3}}, k);
}

Block Draw(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter, std::uint64_t block) {
  return Philox(key, counter, static_cast<std::uint64_t>(purpose), block, 0);
}

// The 256-layer ziggurat for the standard normal (Marsaglia & Tsang 2000, in the form of Doornik
// 2005): layer i is the rectangle [0, x[i]] × [f(x[i]), f(x[i+1])], f(x) = exp(−x²/2), all of area
// kV; layer 0 is the base strip [0, r] plus the tail beyond r, its x[0] = kV/f(r) a pseudo-width.
// ratio[i] = x[i+1]/x[i]: a signed uniform u with |u| < ratio[i] gives u·x[i] at once.
struct Ziggurat {
  static constexpr int kLayers = 256;
  static constexpr double kR = 3.6541528853610088;  // start of the tail
  static constexpr double kV = 4.92867323399e-3;    // area of each layer
  std::array<double, kLayers + 1> x{};
  std::array<double, kLayers> ratio{};
  Ziggurat() {
    double f = std::exp(-0.5 * kR * kR);
    x[0] = kV / f;
    x[1] = kR;
    x[kLayers] = 0.0;
    for (int i = 2; i < kLayers; ++i) {
      x[static_cast<std::size_t>(i)] =
          std::sqrt(-2.0 * std::log(kV / x[static_cast<std::size_t>(i - 1)] + f));
      f = std::exp(-0.5 * x[static_cast<std::size_t>(i)] * x[static_cast<std::size_t>(i)]);
    }
    for (std::size_t i = 0; i < kLayers; ++i) ratio[i] = x[i + 1] / x[i];
  }
};

const Ziggurat& Tables() {
  static const Ziggurat z;
  return z;
}

// A word's signed uniform in (−1, 1) from its top 53 bits (never 0 or ±1), and its layer.
inline double SignedUniform(std::uint64_t w) {
  return (static_cast<double>(static_cast<std::int64_t>(w >> 11)) + 0.5) * 0x1p-52 - 1.0;
}
inline std::size_t Layer(std::uint64_t w) { return static_cast<std::size_t>(w & 0xFF); }
// A uniform in (0, 1) from a word's top 53 bits.
inline double OpenUniform(std::uint64_t w) {
  return (static_cast<double>(static_cast<std::int64_t>(w >> 11)) + 0.5) * 0x1p-53;
}

// Normal number m, whose first word w was rejected by the fast test. Attempt a ≥ 1 draws the block
// (m, kNoiseStreamRetry + 256·a, sub): word 1 decides the wedge of the current candidate, words 2 and
// 3 try the tail, word 0 is the next candidate.
double SlowNormal(const Ziggurat& z, const NoiseKey& key, std::uint64_t m, std::uint64_t w) {
  const auto retry = static_cast<std::uint64_t>(RandomPurpose::kNoiseStreamRetry);
  for (std::uint64_t attempt = 1;; ++attempt) {
    const Block b = Philox(key, m, retry + 256 * attempt, key.sub[0], key.sub[1]);
    const std::size_t i = Layer(w);
    const double u = SignedUniform(w);
    if (i == 0) {  // the tail beyond r (Marsaglia 1964), with further blocks if it rejects
      Block t = b;
      for (std::uint64_t a = attempt;; t = Philox(key, m, retry + 256 * ++a, key.sub[0], key.sub[1])) {
        const double tx = std::log(OpenUniform(t[2])) / Ziggurat::kR;
        const double ty = std::log(OpenUniform(t[3]));
        if (-2.0 * ty >= tx * tx) return u < 0 ? tx - Ziggurat::kR : Ziggurat::kR - tx;
      }
    }
    const double x = u * z.x[i];
    const double f0 = std::exp(-0.5 * (z.x[i] * z.x[i] - x * x));
    const double f1 = std::exp(-0.5 * (z.x[i + 1] * z.x[i + 1] - x * x));
    if (f1 + OpenUniform(b[1]) * (f0 - f1) < 1.0) return x;
    w = b[0];
    if (std::abs(SignedUniform(w)) < z.ratio[Layer(w)]) return SignedUniform(w) * z.x[Layer(w)];
  }
}

inline double Normal(const Ziggurat& z, const NoiseKey& key, std::uint64_t m, std::uint64_t w) {
  const std::size_t i = Layer(w);
  const double u = SignedUniform(w);
  if (std::abs(u) < z.ratio[i]) [[likely]]
    return u * z.x[i];
  return SlowNormal(z, key, m, w);
}

void CheckSigma(const Mat& x, const Vec& sigma) {
  if (sigma.size() != x.rows()) {
    throw std::invalid_argument(
        fmt::format("sigma has {} entries; the state has {}", sigma.size(), x.rows()));
  }
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    if (!(sigma[i] >= 0.0) || !std::isfinite(sigma[i])) {
      throw std::invalid_argument(fmt::format("sigma[{}] = {}: must be finite and >= 0", i, sigma[i]));
    }
  }
}

}  // namespace

Normal4 StandardNormals(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter,
                        std::uint64_t block) {
  const auto r = Draw(key, purpose, counter, block);
  const auto a = r123::boxmuller(r[0], r[1]);
  const auto b = r123::boxmuller(r[2], r[3]);
  return Normal4{{a.x, a.y, b.x, b.y}};
}

Uniform4 Uniforms(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter, std::uint64_t block) {
  const auto r = Draw(key, purpose, counter, block);
  Uniform4 u{};
  for (int i = 0; i < 4; ++i) u.v[i] = r123::u01<double>(r[static_cast<std::size_t>(i)]);
  return u;
}

void FillStandardNormals(const NoiseKey& key, std::uint64_t first, double* out, std::size_t count) {
  const Ziggurat& z = Tables();
  const auto purpose = static_cast<std::uint64_t>(RandomPurpose::kNoiseStream);
  const std::uint64_t end = first + count;
  std::uint64_t m = first;
  // A whole block: the fast test on all four words at once.
  auto whole_block = [&](const Block& b, std::uint64_t at) {
    double v[4];
    bool fast = true;
    for (std::size_t j = 0; j < 4; ++j) {
      const double u = SignedUniform(b[j]);
      v[j] = u * z.x[Layer(b[j])];
      fast &= std::abs(u) < z.ratio[Layer(b[j])];
    }
    double* o = out + (at - first);
    if (fast) [[likely]] {
      for (std::size_t j = 0; j < 4; ++j) o[j] = v[j];
    } else {
      for (std::size_t j = 0; j < 4; ++j) o[j] = Normal(z, key, at + j, b[j]);
    }
  };
  while (m < end) {
    const std::uint64_t c = m / 4;
    if (m % 4 == 0 && m + 8 <= end) {
      // Two independent Philox calls side by side: their multiplications overlap in the pipeline.
      const Block b0 = Philox(key, c, purpose, key.sub[0], key.sub[1]);
      const Block b1 = Philox(key, c + 1, purpose, key.sub[0], key.sub[1]);
      whole_block(b0, m);
      whole_block(b1, m + 4);
      m += 8;
      continue;
    }
    const Block b = Philox(key, c, purpose, key.sub[0], key.sub[1]);
    if (m % 4 == 0 && m + 4 <= end) {
      whole_block(b, m);
      m += 4;
      continue;
    }
    for (; m < end && m / 4 == c; ++m) out[m - first] = Normal(z, key, m, b[m % 4]);
  }
}

Mat AddMeasurementNoise(const Mat& x, const Vec& sigma, const NoiseKey& key) {
  CheckSigma(x, sigma);
  if ((sigma.array() == 0.0).all()) return x;
  Mat y(x.rows(), x.cols());
  FillStandardNormals(key, 0, y.data(), static_cast<std::size_t>(y.size()));
  for (Eigen::Index k = 0; k < x.cols(); ++k) {
    for (Eigen::Index i = 0; i < x.rows(); ++i) y(i, k) = x(i, k) + sigma[i] * y(i, k);
  }
  return y;
}

Mat AddMeasurementNoisePerSample(const Mat& x, const Vec& sigma, const NoiseKey& key) {
  CheckSigma(x, sigma);
  Mat y = x;
  if ((sigma.array() == 0.0).all()) return y;
  const Eigen::Index n = x.rows();
  for (Eigen::Index k = 0; k < x.cols(); ++k) {
    for (Eigen::Index block = 0; block * 4 < n; ++block) {
      const auto r = Draw(key, RandomPurpose::kMeasurementNoise, static_cast<std::uint64_t>(k),
                          static_cast<std::uint64_t>(block));
      for (Eigen::Index pair = 0; pair < 2 && block * 4 + pair * 2 < n; ++pair) {
        const auto e =
            r123::boxmuller(r[static_cast<std::size_t>(2 * pair)], r[static_cast<std::size_t>(2 * pair + 1)]);
        const Eigen::Index i = block * 4 + pair * 2;
        y(i, k) += sigma[i] * e.x;
        if (i + 1 < n) y(i + 1, k) += sigma[i + 1] * e.y;
      }
    }
  }
  return y;
}

}  // namespace hysid

#include "sim/measurement.hpp"

#include <cmath>
#include <stdexcept>

#include <Random123/boxmuller.hpp>
#include <Random123/philox.h>
#include <Random123/uniform.hpp>
#include <fmt/format.h>

namespace hysid {
namespace {

r123::Philox4x64::ctr_type Draw(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter,
                                std::uint64_t block) {
  const r123::Philox4x64 generator;
  const r123::Philox4x64::key_type k = {{key.seed, key.stream}};
  const r123::Philox4x64::ctr_type c = {
      {counter, static_cast<std::uint64_t>(purpose), block, 0}};
  return generator(c, k);
}

}  // namespace

Normal4 StandardNormals(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter,
                        std::uint64_t block) {
  const auto r = Draw(key, purpose, counter, block);
  const auto a = r123::boxmuller(r[0], r[1]);
  const auto b = r123::boxmuller(r[2], r[3]);
  return Normal4{{a.x, a.y, b.x, b.y}};
}

Uniform4 Uniforms(const NoiseKey& key, RandomPurpose purpose, std::uint64_t counter,
                  std::uint64_t block) {
  const auto r = Draw(key, purpose, counter, block);
  Uniform4 u{};
  for (int i = 0; i < 4; ++i) u.v[i] = r123::u01<double>(r[static_cast<std::size_t>(i)]);
  return u;
}

Mat AddMeasurementNoise(const Mat& x, const Vec& sigma, const NoiseKey& key) {
  if (sigma.size() != x.rows()) {
    throw std::invalid_argument(
        fmt::format("sigma has {} entries; the state has {}", sigma.size(), x.rows()));
  }
  for (Eigen::Index i = 0; i < sigma.size(); ++i) {
    if (!(sigma[i] >= 0.0) || !std::isfinite(sigma[i])) {
      throw std::invalid_argument(
          fmt::format("sigma[{}] = {}: must be finite and >= 0", i, sigma[i]));
    }
  }
  Mat y = x;
  if ((sigma.array() == 0.0).all()) return y;
  // One Philox draw gives four uniforms, i.e. two Box–Muller pairs: components 4b..4b+3 of sample k
  // use block b; a pair is transformed only when a component needs it.
  const Eigen::Index n = x.rows();
  for (Eigen::Index k = 0; k < x.cols(); ++k) {
    for (Eigen::Index block = 0; block * 4 < n; ++block) {
      const auto r = Draw(key, RandomPurpose::kMeasurementNoise, static_cast<std::uint64_t>(k),
                          static_cast<std::uint64_t>(block));
      for (Eigen::Index pair = 0; pair < 2 && block * 4 + pair * 2 < n; ++pair) {
        const auto e = r123::boxmuller(r[static_cast<std::size_t>(2 * pair)],
                                       r[static_cast<std::size_t>(2 * pair + 1)]);
        const Eigen::Index i = block * 4 + pair * 2;
        y(i, k) += sigma[i] * e.x;
        if (i + 1 < n) y(i + 1, k) += sigma[i + 1] * e.y;
      }
    }
  }
  return y;
}

}  // namespace hysid

// 95 % intervals of a cell's mean that stay inside the metric's range (summary.csv):
//
// WilsonInterval(p, n, z)      the Wilson score interval of a proportion p observed in n Bernoulli trials
//                              with quantile z: the p0 with |p − p0| ≤ z·√(p0(1 − p0)/n), in closed form
//                              (centre (p + z²/2n)/(1 + z²/n), half-width z·√(p(1−p)/n + z²/4n²)/(1 + z²/n)).
// RateInterval(v)              values in [0, 1] (a rate per trial): the Wilson interval at the effective
//                              sample size n_eff = p̄(1 − p̄)/(s²/n), the number of Bernoulli trials whose
//                              binomial variance equals the observed variance of the mean, and z = t(0.975,
//                              n − 1). For 0/1 values n_eff = n − 1; for any values in [0, 1], n_eff ≥ n − 1
//                              (their variance is at most p̄(1 − p̄)); as n_eff grows it becomes the t-interval
//                              p̄ ± t·s/√n. Inside [0, 1].
// BootstrapMeanInterval(v)     non-negative values (errors, counts): the 2.5 % and 97.5 % quantiles (linear
//                              interpolation) of the means of kBootstrapResamples resamples drawn with
//                              replacement by std::mt19937_64 seeded with kBootstrapSeed; the indices depend
//                              only on n, so the same values give the same bounds on every run and thread
//                              count. Inside [min v, max v], so never below 0 for non-negative values.
// Both return {NaN, NaN} for fewer than 2 values and {v, v} when all values equal v.
// BootstrapPlan(n)             the resample indices of BootstrapMeanInterval for n values, drawn once;
//                              its MeanInterval(v) returns BootstrapMeanInterval(v) bit for bit (each
//                              resample's sum in the same order), so a summary draws them once per
//                              trial count instead of once per metric and cell.
// BootstrapPlans               the plans of a summary by n, made on first use and shared by the threads
//                              that summarise cells in parallel. Its plans hold at most kMaxPlanIndices
//                              indices (32 MB) together; a size that no longer fits draws as
//                              BootstrapMeanInterval does (the same bounds, slower).
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <vector>

namespace hysid {

inline constexpr int kBootstrapResamples = 2000;
inline constexpr std::uint64_t kBootstrapSeed = 20201123;

std::array<double, 2> WilsonInterval(double p, double n, double z);
std::array<double, 2> RateInterval(const std::vector<double>& values);
std::array<double, 2> BootstrapMeanInterval(const std::vector<double>& values);

class BootstrapPlan {
 public:
  explicit BootstrapPlan(std::size_t n);
  std::size_t n() const { return n_; }
  // values.size() must be n.
  std::array<double, 2> MeanInterval(const std::vector<double>& values) const;

 private:
  std::size_t n_;
  std::vector<std::uint32_t> index_;  // resample b's draws at [b·n, (b + 1)·n)
};

class BootstrapPlans {
 public:
  static constexpr std::size_t kMaxPlanIndices = std::size_t{1} << 23;

  std::array<double, 2> MeanInterval(const std::vector<double>& values);

 private:
  // The plan for n values, or null when it does not fit.
  const BootstrapPlan* PlanFor(std::size_t n);

  std::mutex mutex_;
  std::size_t indices_ = 0;  // held by plans_
  std::map<std::size_t, std::unique_ptr<const BootstrapPlan>> plans_;
};

}  // namespace hysid

// The paper's Example 6 (its Fig. 2): the scalar flow ξ' = sin ξ on C = [0, 2π], whose Lipschitz
// constant is k = sup|cos ξ| = 1, with the closed-form solution
//   ξ(t) = 2 atan(exp(t − ln cot(ξ0/2))).
// For a sampling step δt it gives, at time t ≥ δt,
//   the Euler derivative norm  D(t) = |ξ(t) − ξ(t−δt)| / δt                 (Definition 3),
//   the smoothness bound       τ(t) = (k/δt) ∫_{t−δt}^{t} |ξ(s)| ds          (Proposition 5, eq. 2),
//   its trapezoid estimate     τ̂_r(t) = (r/2) k (|ξ(t)| + |ξ(t−δt)|)        (eq. 3 with k̂ = r k).
// Proposition 5 promises D(t) ≤ τ(t); τ̂_1 is τ with the integral taken by the trapezoid rule.
#pragma once

#include <span>

namespace hysid {

struct Example6Options {
  double xi0 = 1e-2;  // ξ(0), in (0, π)
  double dt = 0.5;    // δt
};

struct Example6Point {
  double t = 0, xi = 0, xi_prev = 0;  // ξ(t), ξ(t − δt)
  double euler = 0;                   // D(t)
  double tau = 0;  // τ(t), the integral by 20-point Gauss–Legendre (error < 1e-14 relative)
};

// ξ(t) in closed form.
double Example6State(double t, const Example6Options& options);

// D, τ at time t ≥ δt. Throws std::invalid_argument for t < δt or options outside their ranges.
Example6Point Example6At(double t, const Example6Options& options);

// τ̂_r(t) of eq. (3) with the exact k = 1.
inline double Example6TauHat(const Example6Point& p, double r) { return 0.5 * r * (p.xi + p.xi_prev); }

}  // namespace hysid

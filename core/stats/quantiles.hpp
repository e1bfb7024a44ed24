// Tail quantiles used by the tuning-free jump detector (core/detectors/residual.hpp).
//
// NormalUpperQuantile(p):        z with P(Z > z) = p, Z ~ N(0, 1).
// StudentUpperQuantile(p, nu):   t with P(T > t) = p, T ~ Student t with nu degrees of freedom,
//                                from P(T > t) = I_{nu/(nu+t²)}(nu/2, 1/2) / 2 (regularised
//                                incomplete beta by its continued fraction), solved by bisection.
// Both throw std::invalid_argument for p outside (0, 0.5] or nu < 1; accurate to ~1e-12 relative.
#pragma once

namespace hysid {

double NormalUpperQuantile(double p);
double StudentUpperQuantile(double p, double nu);
// Regularised incomplete beta I_x(a, b) for a, b > 0, x ∈ [0, 1].
double RegularizedIncompleteBeta(double x, double a, double b);

}  // namespace hysid

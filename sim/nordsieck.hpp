// Dense output of CVODE's last step read from its Nordsieck array, to the bit what CVodeGetDky
// returns, without its per-call overhead. Internal to sim/ (used by the hybrid run loop).
//
// CVodeGetDky(t, k) forms k!/h^k · Σ_{j=k..q} (j!/(k!(j−k)!))·s^(j−k) z_n[j], s = (t − t_n)/h, from the
// Nordsieck array z_n[0..q] of the last step. CVODE's public headers do not expose z_n, but its
// vectors are clones of the template vector given to CVodeInit, made one after the other
// (z_n[0], …, z_n[qmax]), and CVodeGetNonlinearSystemData returns z_n[0] and z_n[1]: recording the
// clones that CVodeInit makes finds the whole array. Every order is checked against CVodeGetDky, bit
// for bit, the first time a run uses it; after a mismatch the run uses CVodeGetDky only.
#pragma once

#include <vector>

#include <nvector/nvector_serial.h>

namespace hysid::nordsieck {

// Records the clones of `tmpl` (and of its clones) made while it is alive, on this thread only:
// construct it around CVodeInit. `tmpl` must be a serial vector; its clone operation is replaced by
// one that records (the clones behave as serial vectors otherwise).
class CloneRecorder {
 public:
  explicit CloneRecorder(N_Vector tmpl);
  ~CloneRecorder();
  CloneRecorder(const CloneRecorder&) = delete;
  CloneRecorder& operator=(const CloneRecorder&) = delete;
  const std::vector<N_Vector>& clones() const { return clones_; }

 private:
  std::vector<N_Vector> clones_;
  std::vector<N_Vector>* previous_ = nullptr;
};

class History {
 public:
  // Finds z_n[0..] among `clones` (the recorder's, after CVodeInit). Without a match (another
  // CVODE version) available() stays false.
  void Locate(void* cvode_mem, const std::vector<N_Vector>& clones, long n);
  bool available() const { return !zn_.empty() && !broken_; }

  // For the last step (order q, t_n, h, read from CVODE): true if the direct read can be used,
  // checking order q against CVodeGetDky (into `scratch`) the first time it occurs. Also false
  // when z_n[0..q] is not finite (CVodeGetDky's products with s = 0 keep NaN there).
  bool Prepare(void* cvode_mem, int q, double tn, double h, N_Vector scratch);

  // CVodeGetDky(t, k) for the step of the last Prepare, into out[0..n): the same products and sums in
  // the same order as SUNDIALS 6.4's CVodeGetDky with N_VLinearCombination_Serial.
  void Dky(double t, int k, double* out) const;
  // The same at t = t_n, where every term but z_n[k]'s is zero: k!/h^k · z_n[k] when that is not
  // zero (a zero goes through Dky for the sign of the sum of the zero terms).
  void DkyAtTn(int k, double* out) const;

 private:
  bool CheckOrder(void* cvode_mem, N_Vector scratch);
  static constexpr int kPowers = 13;  // s^0..s^12: CVODE's Adams orders go up to 12

  std::vector<const double*> zn_;
  long n_ = 0;
  int checked_order_ = 0;
  bool broken_ = false;
  int q_ = 0;
  double tn_ = 0.0;
  double h_ = 0.0;
};

}  // namespace hysid::nordsieck

#include "sim/nordsieck.hpp"

#include <cmath>
#include <cstring>

#include <cvodes/cvodes.h>

namespace hysid::nordsieck {
namespace {

thread_local std::vector<N_Vector>* t_clone_log = nullptr;

N_Vector RecordingClone(N_Vector w) {
  N_Vector v = N_VClone_Serial(w);
  if (v != nullptr && t_clone_log != nullptr) t_clone_log->push_back(v);
  return v;
}

}  // namespace

CloneRecorder::CloneRecorder(N_Vector tmpl) : previous_(t_clone_log) {
  tmpl->ops->nvclone = RecordingClone;
  t_clone_log = &clones_;
}

CloneRecorder::~CloneRecorder() { t_clone_log = previous_; }

void History::Locate(void* cvode_mem, const std::vector<N_Vector>& clones, long n) {
  zn_.clear();
  n_ = n;
  sunrealtype tcur = 0.0, gamma = 0.0, rl1 = 0.0;
  N_Vector zn0 = nullptr, y = nullptr, f = nullptr, zn1 = nullptr;
  void* user_data = nullptr;
  if (CVodeGetNonlinearSystemData(cvode_mem, &tcur, &zn0, &y, &f, &gamma, &rl1, &zn1, &user_data) !=
      CV_SUCCESS) {
    return;
  }
  for (std::size_t i = 0; i + 1 < clones.size(); ++i) {
    if (clones[i] != zn0 || clones[i + 1] != zn1) continue;
    for (std::size_t j = i; j < clones.size(); ++j) zn_.push_back(N_VGetArrayPointer_Serial(clones[j]));
    return;
  }
}

bool History::Prepare(void* cvode_mem, int q, double tn, double h, N_Vector scratch) {
  if (!available() || q < 1 || q >= static_cast<int>(zn_.size()) || h == 0.0) return false;
  q_ = q;
  tn_ = tn;
  h_ = h;
  for (int j = 0; j <= q; ++j) {
    for (long i = 0; i < n_; ++i) {
      if (!std::isfinite(zn_[j][i])) return false;
    }
  }
  if (q <= checked_order_) return true;
  if (!CheckOrder(cvode_mem, scratch)) {
    broken_ = true;
    return false;
  }
  checked_order_ = q;
  return true;
}

// Compares Dky and DkyAtTn with CVodeGetDky for k = 0..q at t_n and for k = 0 inside the step.
bool History::CheckOrder(void* cvode_mem, N_Vector scratch) {
  std::vector<double> direct(static_cast<std::size_t>(n_));
  const double* cvode = N_VGetArrayPointer_Serial(scratch);
  const auto bytes = static_cast<std::size_t>(n_) * sizeof(double);
  for (int k = 0; k <= q_; ++k) {
    if (CVodeGetDky(cvode_mem, tn_, k, scratch) != CV_SUCCESS) return false;
    Dky(tn_, k, direct.data());
    if (std::memcmp(direct.data(), cvode, bytes) != 0) return false;
    DkyAtTn(k, direct.data());
    if (std::memcmp(direct.data(), cvode, bytes) != 0) return false;
  }
  const double t = tn_ - 0.375 * h_;
  if (CVodeGetDky(cvode_mem, t, 0, scratch) != CV_SUCCESS) return false;
  Dky(t, 0, direct.data());
  return std::memcmp(direct.data(), cvode, bytes) == 0;
}

void History::Dky(double t, int k, double* out) const {
  const double s = (t - tn_) / h_;
  if (k == 0 && q_ < kPowers) {
    // c_j = s^j, formed as the loop below forms it (1 times s, j times), once for every j.
    double power[kPowers];
    power[0] = 1.0;
    for (int j = 1; j <= q_; ++j) power[j] = power[j - 1] * s;
    for (long i = 0; i < n_; ++i) out[i] = power[q_] * zn_[q_][i];
    for (int j = q_ - 1; j >= 0; --j) {
      for (long i = 0; i < n_; ++i) out[i] += power[j] * zn_[j][i];
    }
    return;
  }
  for (int j = q_; j >= k; --j) {
    double c = 1.0;
    for (int i = j; i >= j - k + 1; --i) c *= i;
    for (int i = 0; i < j - k; ++i) c *= s;
    const double* z = zn_[j];
    if (j == q_) {
      for (long i = 0; i < n_; ++i) out[i] = c * z[i];
    } else {
      for (long i = 0; i < n_; ++i) out[i] += c * z[i];
    }
  }
  if (k == 0) return;
  double power = 1.0;  // SUNRpowerI(h, -k)
  for (int i = 1; i <= k; ++i) power *= h_;
  const double r = 1.0 / power;
  for (long i = 0; i < n_; ++i) out[i] *= r;
}

void History::DkyAtTn(int k, double* out) const {
  double factorial = 1.0;
  for (int i = k; i >= 1; --i) factorial *= i;
  const double* z = zn_[k];
  for (long i = 0; i < n_; ++i) {
    out[i] = factorial * z[i];
    if (out[i] == 0.0 && k < q_) {
      Dky(tn_, k, out);
      return;
    }
  }
  if (k == 0) return;
  double power = 1.0;
  for (int i = 1; i <= k; ++i) power *= h_;
  const double r = 1.0 / power;
  for (long i = 0; i < n_; ++i) out[i] *= r;
}

}  // namespace hysid::nordsieck

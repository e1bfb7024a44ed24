// The paper's jump detector (§3, eq. 3): γ(t) = 1 when the Euler derivative
//   D_δt ξ(t) = ‖ξ(t) − ξ(t−δt)‖ / δt
// exceeds the estimated smoothness bound
//   τ̂(t) = (r/2) · L̂ · (‖ξ(t)‖ + ‖ξ(t−δt)‖),   L̂ = sup_{ξ∈Ĉ} ‖∂f̂_r/∂ξ‖,
// where f̂_r are the identified rows of the estimated flow φ(ξ)α̂ (§5: L̂ = ‖α̂‖ for impact-msd).
// τ̂ = τ̂0 until the α estimator has seen as many flow samples as it has unknowns.
//
// Bound modes (DetectorSettings::bound):
//   paper        as above;
//   homogeneous  for affine flows (f(0) ≠ 0, e.g. gravity), where ‖f(ξ)‖ ≤ L‖ξ‖ fails near ξ = 0:
//                ξ̄ = [ξ; 1], L̂ = ‖[∂f̂_r/∂ξ, f̂_r(0)]‖, norms ‖ξ̄‖ — then ‖f(ξ)‖ ≤ L̂‖ξ̄‖ holds.
//   auto         paper when φ_r(0) = 0 (f̂_r(0) = 0 for every α̂), homogeneous otherwise.
// The sup over Ĉ: constant Jacobians (ModelSpec::flow_jacobian_constant) need one evaluation; others
// are evaluated at the vertices of Ĉ (the hull of Λ) and at ξ(t−δt), ξ(t) — the exact sup for a
// norm convex in ξ over a polytope, an approximation otherwise.
// A model with inputs u: always homogeneous, f̂_r(0) = f̂_r(0, u) moves with u, so L̂ is the larger of
// its values at ξ(t−δt) and ξ(t), each with its own u (‖f(ξ, u)‖ ≤ L̂‖ξ̄‖ along the pair for a flow
// affine in ξ); the vertices of Ĉ, whose u is not kept, are not used.
#pragma once

#include <cmath>
#include <string>
#include <vector>

#include "core/detectors/detector.hpp"

namespace hysid {

enum class BoundMode { kPaper, kHomogeneous };

// Resolves BoundRule::kAuto for a model.
BoundMode ResolveBoundMode(BoundRule bound, const Model& model);

// L̂ for the full parameter vector `alpha` at the states in the columns of `points` (at least one
// column; only one is used when the Jacobian is constant).
double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points);
// The same with caller-owned work space (no allocation once it has the right sizes).
struct JacobianScratch {
  Mat jac, reduced;
  Vec f0, zero;
};
double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points, JacobianScratch& scratch);
// The same with every point evaluated at the context `at` (a model with inputs).
double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points, JacobianScratch& scratch, const Context& at);

// Whether the paper's bound can hold for the whole flow: τ̂ ≈ r·L̂·‖ξ‖ covers ‖f̂(ξ)‖ ≤ ‖∂f̂/∂ξ‖·‖ξ‖
// only while the Jacobian of every row (known rows included) is within r·L̂, L̂ taken from the
// identified rows. States of very different scales break it (the known row ξ1' = ξ2 with ξ2 in
// units 1e-6 of ξ1: L̂ shrinks by 1e-6, the known row's norm does not) and every flow sample where
// the known rows move fast becomes a false jump. Returns why it fails (sup over `points`, e.g. the
// samples), or "" when it holds. Not a property of the paper's own examples (there the ratio is ≈ 1).
std::string CheckPaperBound(const Model& model, ConstVecRef alpha, const DetectorSettings& settings,
                            const Eigen::Ref<const Mat>& points);

// λmax(AAᵀ) = ‖A‖₂².
double SpectralNormSquared(const Eigen::Ref<const Mat>& a);

// ‖ξ‖ (paper) or ‖[ξ; 1]‖ (homogeneous).
inline double BoundNorm(const double* x, Eigen::Index n, BoundMode mode) {
  double s = 0.0;
  for (Eigen::Index i = 0; i < n; ++i) s += x[i] * x[i];
  return std::sqrt(mode == BoundMode::kHomogeneous ? s + 1.0 : s);
}
inline double BoundNorm(ConstVecRef x, BoundMode mode) { return BoundNorm(x.data(), x.size(), mode); }

namespace detail {

// αᵀQα for a symmetric p × p matrix Q (column-major); P = p when known at compile time, else 0.
template <int P>
[[gnu::always_inline]] inline double QuadraticForm(Eigen::Index p_dynamic, const double* q,
                                                   const double* alpha) {
  const Eigen::Index p = P > 0 ? P : p_dynamic;
  double s = 0.0;
  for (Eigen::Index c = 0; c < p; ++c) {
    double qa = 0.0;
    for (Eigen::Index r = 0; r < p; ++r) qa += q[c * p + r] * alpha[r];
    s += alpha[c] * qa;
  }
  return s;
}

// What the paper detector takes from a pair ξ(t−δt), ξ(t) of n states alone, whatever α̂: D² and
// D = ‖ξ(t) − ξ(t−δt)‖/δt, and ‖ξ(t)‖ in the bound's norm (homogeneous: ‖[ξ; 1]‖); every path's. Square
// roots are the costly instructions here: D and ‖ξ(t)‖ share one packed square root. The sums start
// at the first square instead of +0: a square is never −0, so +0 + x² is x², bit for bit.
struct PairTerms {
  double d2, statistic, cur_norm;

  // N = n when known at compile time (the loop unrolls), else 0; n ≥ 1.
  template <int N = 0>
  [[gnu::always_inline]] static PairTerms Of(const double* prev, const double* cur, Eigen::Index n_dynamic,
                                             double inv_dt, bool homogeneous) {
    const Eigen::Index n = N > 0 ? N : n_dynamic;
    double v = (cur[0] - prev[0]) * inv_dt;
    double d2 = v * v, cur2 = cur[0] * cur[0];
    for (Eigen::Index i = 1; i < n; ++i) {
      v = (cur[i] - prev[i]) * inv_dt;
      d2 += v * v;
      cur2 += cur[i] * cur[i];
    }
    if (homogeneous) cur2 += 1.0;
    const Eigen::Array2d roots = Eigen::Array2d(d2, cur2).sqrt();
    return {d2, roots[0], roots[1]};
  }
  // Two states in scalars: ξ(t−δt) = (p0, p1), ξ(t) = (c0, c1).
  [[gnu::always_inline]] static PairTerms Of(double p0, double p1, double c0, double c1, double inv_dt,
                                             bool homogeneous) {
    const double prev[2] = {p0, p1}, cur[2] = {c0, c1};
    return Of<2>(prev, cur, 2, inv_dt, homogeneous);
  }
};
// The paper detector's decision (eq. 3), the one rule of every path: γ = 1 when D > τ̂,
// τ̂ = (r/2)·L̂·s with s = ‖ξ(t)‖ + ‖ξ(t−δt)‖ in the bound's norm. Taken on squares, D² > τ̂² (d2 = D²,
// l2 = L̂², half_r = r/2), so that no square root sits on the chain α̂ → τ̂ → γ → α̂ of consecutive
// samples.
[[gnu::always_inline]] inline bool PaperFlags(double d2, double half_r, double l2, double s) {
  return d2 > half_r * half_r * l2 * s * s;
}
// The decision with its statistic D and threshold τ̂ (l = L̂ = √l2, computed off that chain).
[[gnu::always_inline]] inline Decision PaperDecision(const PairTerms& pair, double half_r, double l2,
                                                     double l, double s) {
  return {
      .gamma = PaperFlags(pair.d2, half_r, l2, s), .statistic = pair.statistic, .threshold = half_r * l * s};
}

// ClassifyConstant<2, true>'s state and arithmetic for two states, one identified row and A = |α|
// (2 or 3) with two unknowns, in scalars: for a loop that keeps them in local variables over a run
// of consecutive samples (the identifier's flow runs; PaperDetector::LoadConstant2,
// StoreConstant2). The same bits as ClassifyConstant, with fewer operations where they provably
// cannot change a bit (see Classify and NormSquared).
template <int A>
struct PaperConstant2 {
  double half_r;
  double q[A * A];  // GᵀG, column-major
  double alpha[A];  // α̂ with its known entries; the unknowns at u0, u1
  int u0, u1;
  bool homogeneous;
  double last_x0, last_x1, last_norm;  // the previous call's ξ(t) and its norm
  bool has_last;
  long cached_version;
  double cached_l2, cached_l;
  // GᵀG is zero outside (u0, u0) and (u1, u1), u0 < u1, and every entry of GᵀG and α̂'s known
  // entries is finite (LoadConstant2): the unknowns do not mix in ‖J̄_r(α)‖² and the known entries
  // do not enter it, ‖J̄_r(α)‖² = t0·(q0·t0) + t1·(q1·t1) up to the sign of a zero (NormSquared).
  bool separable;
  double q0, q1;  // GᵀG at (u0, u0) and (u1, u1)

  // ‖ξ(t−δt)‖ of a pair: the previous call's ‖ξ(t)‖ when ξ(t−δt) is that ξ(t).
  double PrevNorm(double p0, double p1) const {
    if (has_last && last_x0 == p0 && last_x1 == p1) return last_norm;
    const double x[2] = {p0, p1};
    return BoundNorm(x, 2, homogeneous ? BoundMode::kHomogeneous : BoundMode::kPaper);
  }
  // ‖J̄_r(α̂)‖² = α̂ᵀGᵀGα̂ for the unknowns (t0, t1), with QuadraticForm<A>'s bits. Separable: the
  // terms of QuadraticForm's sums that hold a zero entry of GᵀG are ±0 (the known entries and
  // t0, t1 finite), and adding ±0 to a sum changes at most the sign of a zero sum; so
  // t0·(q0·t0) + t1·(q1·t1), in QuadraticForm's order, has its bits unless it is zero (or t0, t1 are
  // not finite), where the full form is taken.
  [[gnu::always_inline]] double NormSquared(double t0, double t1) {
    if (separable) {
      const double l2 = t0 * (q0 * t0) + t1 * (q1 * t1);
      if (l2 != 0.0 && std::isfinite(t0 + t1)) return l2;
    }
    alpha[u0] = t0;
    alpha[u1] = t1;
    return QuadraticForm<A>(A, q, alpha);
  }
  // The decision for ξ(t) = (c0, c1) after ξ(t−δt) = (p0, p1), whose norm is prev_norm, with the
  // unknowns of α̂ = (t0, t1); warm-up over. ‖ξ(t)‖ goes to *cur_norm; the caller keeps the pair's
  // state (last_x0, last_x1, last_norm, has_last) and the cache (cached_*) itself.
  [[gnu::always_inline]] Decision Classify(double p0, double p1, double c0, double c1, double prev_norm,
                                           double inv_dt, double t0, double t1, double* cur_norm) {
    const PairTerms pair = PairTerms::Of(p0, p1, c0, c1, inv_dt, homogeneous);
    const double l2 = NormSquared(t0, t1);
    *cur_norm = pair.cur_norm;
    return PaperDecision(pair, half_r, l2, std::sqrt(l2), pair.cur_norm + prev_norm);
  }
  // The cache as ClassifyConstant leaves it after a call at `version` with the unknowns (t0, t1).
  void Cache(long version, double t0, double t1) {
    cached_l2 = NormSquared(t0, t1);
    cached_l = std::sqrt(cached_l2);
    cached_version = version;
  }
  // Classify in two parts, for one caller that classifies consecutive samples with several
  // detectors of one bound mode (core/identify/lockstep.cpp): Decide with the pair's terms computed
  // once for all, and Saw, which only the last sample classified needs before the state is stored.
  void Saw(double c0, double c1, double norm) {
    has_last = true;
    last_x0 = c0;
    last_x1 = c1;
    last_norm = norm;
  }
  // kThreshold false: no d.threshold, and cached_l is left for Settle (which the caller must call
  // before the state is stored): L̂ itself only enters the threshold reported.
  template <bool kThreshold = true>
  [[gnu::always_inline]] Decision Decide(const PairTerms& pair, double prev_norm, double t0, double t1,
                                         long version) {
    if (version != cached_version) {
      cached_l2 = NormSquared(t0, t1);
      if constexpr (kThreshold) cached_l = std::sqrt(cached_l2);
      cached_version = version;
    }
    const double s = pair.cur_norm + prev_norm;
    if constexpr (kThreshold) return PaperDecision(pair, half_r, cached_l2, cached_l, s);
    return {.gamma = PaperFlags(pair.d2, half_r, cached_l2, s), .statistic = pair.statistic};
  }
  void Settle() { cached_l = std::sqrt(cached_l2); }
};

}  // namespace detail

// L̂ = max over the vertices ξ_v of Ĉ of n_v(α) = ‖J̄_r(ξ_v, α)‖₂ for a Jacobian that depends on ξ,
// exact, without evaluating every vertex whenever α̂ changes. J̄_r is linear in α, so
//   |n_v(α) − n_v(α0)| ≤ Δ(α) = Σ_k |α_k − α0_k| M_k,   M_k = max_v ‖J̄_r(ξ_v, e_k)‖₂.
// At a refresh (new vertices, or Δ beyond the margin m = 1e-3·L̂(α0)) every n_v(α0) is evaluated and
// the candidates are the vertices with n_v(α0) ≥ L̂(α0) − 2m. While Δ(α) ≤ m, a vertex outside them
// has n_v(α) < L̂(α0) − m ≤ n_{v*}(α) (v* the maximiser at α0), so the maximum over the candidates is
// the maximum over all vertices. The margin only trades refreshes for candidates; the value is exact.
class VertexJacobianSup {
 public:
  VertexJacobianSup(const Model& model, BoundMode mode);
  // New vertex set (n × h, h ≥ 1): forces a refresh at the next Sup.
  void SetPoints(const Mat& points);
  double Sup(ConstVecRef alpha);  // L̂(α); 0 without points
  long refreshes() const { return refreshes_; }
  std::size_t candidates() const { return candidates_.size(); }

 private:
  void Refresh(ConstVecRef alpha);
  double NormAt(Eigen::Index v, ConstVecRef alpha) const;

  Model model_;
  BoundMode mode_;
  Mat points_;
  Vec column_sup_;  // M_k
  mutable JacobianScratch scratch_;
  Vec alpha0_;
  Vec norms_;  // n_v(α0) at the last refresh (work space)
  double sup0_ = 0.0, margin_ = 0.0;
  std::vector<Eigen::Index> candidates_;
  bool stale_ = true;
  long refreshes_ = 0;
};

// Reads r, tau0 and bound; reports D_δt ξ and τ̂.
DetectorDescriptor PaperDetectorDescriptor();

class PaperDetector final : public JumpDetector {
 public:
  PaperDetector(const DetectorSettings& settings, const Model& model);
  Decision Classify(const SampleContext& context) override;
  std::string name() const override { return "paper"; }
  std::unique_ptr<JumpDetector> CloneWith(const DetectorSettings& settings) const override;
  // Whether a paper detector with factor r and this one's learned state flags the pair (prev, cur)
  // that this one classified last, by ClassifyConstant, and flagged: the same bits as that detector's
  // own ClassifyConstant. `flow_updates` as there (in the warm-up, τ̂0 decides for every r).
  bool FlagsWith(double r, const double* prev, const double* cur, Eigen::Index n, double dt,
                 long flow_updates) const;
  // One identified flow row: ‖J̄_r(α)‖² is a quadratic form in α (ClassifyConstant<N, true>).
  bool one_row() const { return reduced_rows_ == 1; }
  // ClassifyConstant<2, true> in local variables (detail::PaperConstant2<A>, α̂ = `alpha` with its
  // unknowns at u0, u1): for a model with a constant flow Jacobian, two states, one identified row
  // and A = |α|.
  bool constant2(int a) const {
    return constant_jacobian_ && reduced_rows_ == 1 && gram_.rows() == a && (a == 2 || a == 3);
  }
  long unknowns() const { return unknowns_; }
  template <int A>
  detail::PaperConstant2<A> LoadConstant2(const double* alpha, int u0, int u1) const {
    detail::PaperConstant2<A> c{};
    c.half_r = 0.5 * settings_.r;
    for (int i = 0; i < A * A; ++i) c.q[i] = gram_.data()[i];
    for (int i = 0; i < A; ++i) c.alpha[i] = alpha[i];
    c.u0 = u0;
    c.u1 = u1;
    c.homogeneous = mode_ == BoundMode::kHomogeneous;
    c.last_x0 = last_x_[0];
    c.last_x1 = last_x_[1];
    c.last_norm = last_norm_;
    c.has_last = last_n_ == 2;
    c.cached_version = cached_version_;
    c.cached_l2 = cached_l2_;
    c.cached_l = cached_l_;
    c.q0 = c.q[u0 * A + u0];
    c.q1 = c.q[u1 * A + u1];
    c.separable = u0 < u1;
    for (int i = 0; i < A; ++i) {
      if (i != u0 && i != u1 && !std::isfinite(alpha[i])) c.separable = false;
      for (int j = 0; j < A; ++j) {
        const double v = c.q[j * A + i];
        if (!std::isfinite(v) || (v != 0.0 && !(i == j && (i == u0 || i == u1)))) c.separable = false;
      }
    }
    return c;
  }
  template <int A>
  void StoreConstant2(const detail::PaperConstant2<A>& c) {
    last_x_[0] = c.last_x0;
    last_x_[1] = c.last_x1;
    last_norm_ = c.last_norm;
    if (c.has_last) last_n_ = 2;
    cached_version_ = c.cached_version;
    cached_l2_ = c.cached_l2;
    cached_l_ = c.cached_l;
  }
  void Reset() override;

  // The decision for a model with a constant flow Jacobian, from the pair ξ(t−δt), ξ(t) (n entries
  // each), δt and the full α̂ alone: Classify's path for such models, and the identifier's direct
  // (non-virtual, inlined) call. `version` changes whenever α̂ does; `flow_updates` as in
  // SampleContext. N = n when known at compile time (the loops over ξ unroll), else 0.
  //
  // The decision is taken on squares, D² > τ̂², so that no square root sits on the chain
  // α̂ → τ̂ → γ → α̂ of consecutive samples; D and τ̂ themselves are computed off that chain.
  // kOneRow: the caller knows that one_row() holds (no call to the general norm in the code).
  template <int N = 0, bool kOneRow = false>
  [[gnu::always_inline]] Decision ClassifyConstant(const double* prev, const double* cur, Eigen::Index n,
                                                   double dt, const double* alpha_hat, long version,
                                                   long flow_updates) {
    double prev_norm;
    const detail::PairTerms pair = Prologue<N>(prev, cur, n, dt, &prev_norm);
    Decision d;
    if (WarmUp(pair, flow_updates, &d)) return d;
    if (version != cached_version_) {
      cached_l2_ = kOneRow ? OneRowNormSquared(alpha_hat) : LinearNormSquared(alpha_hat);
      cached_l_ = std::sqrt(cached_l2_);
      cached_version_ = version;
    }
    return detail::PaperDecision(pair, 0.5 * settings_.r, cached_l2_, cached_l_, pair.cur_norm + prev_norm);
  }

 private:
  // Until α̂ has seen as many flow samples as it has unknowns: τ̂ = τ̂0. True when that decides (*d).
  bool WarmUp(const detail::PairTerms& pair, long flow_updates, Decision* d) const {
    if (flow_updates >= unknowns_) return false;
    *d = {.gamma = pair.statistic > settings_.tau0, .statistic = pair.statistic, .threshold = settings_.tau0};
    return true;
  }
  // The pair's terms, and ‖ξ(t−δt)‖ in the bound's norm: the previous call's ‖ξ(t)‖ when the pairs
  // are consecutive.
  template <int N = 0>
  [[gnu::always_inline]] detail::PairTerms Prologue(const double* prev, const double* cur,
                                                    Eigen::Index n_dynamic, double dt, double* prev_norm) {
    const Eigen::Index n = N > 0 ? N : n_dynamic;
    const detail::PairTerms pair =
        detail::PairTerms::Of<N>(prev, cur, n, 1.0 / dt, mode_ == BoundMode::kHomogeneous);
    bool consecutive = last_n_ == n;
    for (Eigen::Index i = 0; consecutive && i < n; ++i) consecutive = last_x_[i] == prev[i];
    *prev_norm = consecutive ? last_norm_ : BoundNorm(prev, n, mode_);
    last_n_ = n;
    for (Eigen::Index i = 0; i < n; ++i) last_x_[i] = cur[i];
    last_norm_ = pair.cur_norm;
    return pair;
  }
  // ‖J̄_r(α)‖₂² for a constant Jacobian. One identified row: ‖Gα‖² = αᵀ(GᵀG)α with GᵀG
  // precomputed; more rows: the spectral norm of the reshaped Gα.
  double LinearNormSquared(const double* alpha) {
    return reduced_rows_ != 1 ? SpectralLinearNormSquared(alpha) : OneRowNormSquared(alpha);
  }
  [[gnu::always_inline]] double OneRowNormSquared(const double* alpha) const {
    const Eigen::Index p = gram_.rows();
    const double* q = gram_.data();
    switch (p) {
      case 1: return detail::QuadraticForm<1>(p, q, alpha);
      case 2: return detail::QuadraticForm<2>(p, q, alpha);
      case 3: return detail::QuadraticForm<3>(p, q, alpha);
      case 4: return detail::QuadraticForm<4>(p, q, alpha);
      default: return detail::QuadraticForm<0>(p, q, alpha);
    }
  }
  double SpectralLinearNormSquared(const double* alpha);
  // L̂² of Classify's general path: over Ĉ's vertices and the pair, or (a model with inputs) the pair alone.
  double HullNormSquared(const SampleContext& c);
  double PairNormSquared(const SampleContext& c);

  DetectorSettings settings_;  // reads r, tau0 and bound
  BoundMode mode_;
  bool constant_jacobian_;
  bool inputs_;  // the model has inputs (PairNormSquared)
  int unknowns_;
  // Constant Jacobians are linear in α: vec(J̄_r(α)) = G α, G precomputed (rows × |α|) from unit α.
  Mat g_;
  int reduced_rows_ = 0;
  Vec jvec_;
  Mat gram_;  // GᵀG (|α| × |α|): ‖J̄_r(α)‖² = αᵀGᵀGα for one identified row
  // Cache of the part of L̂ that depends only on α̂ and Ĉ.
  long cached_version_ = -1;
  long cached_hull_version_ = -1;
  double cached_l2_ = 0.0;
  double cached_l_ = 0.0;  // √cached_l2_ (constant Jacobians)
  // ξ(t) of the previous call and its BoundNorm: the next call's ξ(t−δt) when pairs are consecutive.
  double last_x_[Model::kMaxStates] = {};
  Eigen::Index last_n_ = 0;  // 0: no previous call
  double last_norm_ = 0.0;
  VertexJacobianSup vertex_sup_;
  JacobianScratch scratch_;
  Mat pair_;
};

}  // namespace hysid

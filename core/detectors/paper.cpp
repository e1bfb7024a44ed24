#include "core/detectors/paper.hpp"

#include <cmath>
#include <stdexcept>

#include <Eigen/Eigenvalues>
#include <fmt/format.h>

#include "core/sets/sample_set.hpp"

namespace hysid {

// Squared spectral norm of a small matrix: the squared row norm for one row, else λmax(AAᵀ).
[[gnu::noinline]] double SpectralNormSquared(const Eigen::Ref<const Mat>& a) {
  if (a.rows() == 1) return a.row(0).squaredNorm();
  const Mat g = a.rows() <= a.cols() ? Mat(a * a.transpose()) : Mat(a.transpose() * a);
  const Eigen::SelfAdjointEigenSolver<Mat> eig(g, Eigen::EigenvaluesOnly);
  return std::max(0.0, eig.eigenvalues().maxCoeff());
}

BoundMode ResolveBoundMode(BoundRule bound, const Model& model) {
  if (model.input_size() > 0) return BoundMode::kHomogeneous;  // f(0, u) ≠ 0 in general
  if (bound == BoundRule::kPaper) return BoundMode::kPaper;
  if (bound == BoundRule::kHomogeneous) return BoundMode::kHomogeneous;
  const int n = model.state_size();
  Mat phi(n, model.alpha_size());
  model.Phi(Vec::Zero(n), phi);
  for (int r : model.spec().flow_rows) {
    if (phi.row(r).any()) return BoundMode::kHomogeneous;
  }
  return BoundMode::kPaper;
}

double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points) {
  JacobianScratch scratch;
  return SupJacobianNorm(model, alpha, mode, points, scratch);
}

namespace {

// sup over `points` of ‖J̄_rows(ξ, α)‖₂ for the given rows of the flow (homogeneous: with f(0)), every
// point at the context `at`.
double SupRowsJacobianNorm(const Model& model, const std::vector<int>& rows, ConstVecRef alpha,
                           BoundMode mode, const Eigen::Ref<const Mat>& points, JacobianScratch& scratch,
                           const Context& at) {
  const int n = model.state_size();
  const int nr = static_cast<int>(rows.size());
  Mat& jac = scratch.jac;
  Mat& reduced = scratch.reduced;
  Vec& f0 = scratch.f0;
  jac.resize(n, n);
  reduced.resize(nr, mode == BoundMode::kHomogeneous ? n + 1 : n);
  f0.resize(n);
  if (mode == BoundMode::kHomogeneous) {
    scratch.zero.setZero(n);
    model.Flow(scratch.zero, alpha, f0, at);
  }
  const Eigen::Index count = model.spec().flow_jacobian_constant ? 1 : points.cols();
  double sup = 0.0;
  for (Eigen::Index k = 0; k < count; ++k) {
    model.FlowJacobian(points.col(k), alpha, jac, at);
    for (int i = 0; i < nr; ++i) {
      reduced.row(i).head(n) = jac.row(rows[static_cast<std::size_t>(i)]);
      if (mode == BoundMode::kHomogeneous) reduced(i, n) = f0[rows[static_cast<std::size_t>(i)]];
    }
    sup = std::max(sup, std::sqrt(SpectralNormSquared(reduced)));
  }
  return sup;
}

}  // namespace

double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points, JacobianScratch& scratch) {
  return SupRowsJacobianNorm(model, model.spec().flow_rows, alpha, mode, points, scratch, Context{});
}

double SupJacobianNorm(const Model& model, ConstVecRef alpha, BoundMode mode,
                       const Eigen::Ref<const Mat>& points, JacobianScratch& scratch, const Context& at) {
  return SupRowsJacobianNorm(model, model.spec().flow_rows, alpha, mode, points, scratch, at);
}

std::string CheckPaperBound(const Model& model, ConstVecRef alpha, const DetectorSettings& settings,
                            const Eigen::Ref<const Mat>& points) {
  // A model with inputs: the bound is taken per pair with its inputs (Classify); the hull's points keep no u.
  if (points.cols() == 0 || !alpha.allFinite() || model.input_size() > 0) return "";
  const BoundMode mode = ResolveBoundMode(settings.bound, model);
  std::vector<int> all(static_cast<std::size_t>(model.state_size()));
  for (int i = 0; i < model.state_size(); ++i) all[static_cast<std::size_t>(i)] = i;
  JacobianScratch scratch;
  const double identified =
      SupRowsJacobianNorm(model, model.spec().flow_rows, alpha, mode, points, scratch, Context{});
  const double whole = SupRowsJacobianNorm(model, all, alpha, mode, points, scratch, Context{});
  if (!(whole > settings.r * identified)) return "";
  return fmt::format(
      "the paper detector's bound cannot hold: the whole flow's Jacobian norm {:.3g} exceeds r L^ = {:.3g} "
      "(L^ = {:.3g} from the identified rows alone), so flow between samples can exceed tau^ and count as "
      "jumps (states of very different scales? rescale them, or use the residual detector)",
      whole, settings.r * identified, identified);
}

VertexJacobianSup::VertexJacobianSup(const Model& model, BoundMode mode) : model_(model), mode_(mode) {}

void VertexJacobianSup::SetPoints(const Mat& points) {
  points_ = points;
  stale_ = true;
  const int p = model_.alpha_size();
  column_sup_.setZero(p);
  for (int k = 0; k < p; ++k) {
    const Vec unit = Vec::Unit(p, k);
    for (Eigen::Index v = 0; v < points_.cols(); ++v)
      column_sup_[k] = std::max(column_sup_[k], NormAt(v, unit));
  }
}

double VertexJacobianSup::NormAt(Eigen::Index v, ConstVecRef alpha) const {
  return SupJacobianNorm(model_, alpha, mode_, points_.col(v), scratch_);
}

void VertexJacobianSup::Refresh(ConstVecRef alpha) {
  ++refreshes_;
  alpha0_ = alpha;
  const Eigen::Index h = points_.cols();
  Vec& norms = norms_;
  norms.resize(h);
  for (Eigen::Index v = 0; v < h; ++v) norms[v] = NormAt(v, alpha);
  sup0_ = h > 0 ? norms.maxCoeff() : 0.0;
  margin_ = 1e-3 * sup0_;
  candidates_.clear();
  for (Eigen::Index v = 0; v < h; ++v) {
    if (norms[v] >= sup0_ - 2.0 * margin_) candidates_.push_back(v);
  }
  stale_ = false;
}

double VertexJacobianSup::Sup(ConstVecRef alpha) {
  if (points_.cols() == 0) return 0.0;
  if (!stale_) {
    double delta = 0.0;
    for (Eigen::Index k = 0; k < alpha.size(); ++k) delta += std::abs(alpha[k] - alpha0_[k]) * column_sup_[k];
    stale_ = !(delta <= margin_);
  }
  if (stale_) {
    Refresh(alpha);
    return sup0_;
  }
  double sup = 0.0;
  for (Eigen::Index v : candidates_) sup = std::max(sup, NormAt(v, alpha));
  return sup;
}

PaperDetector::PaperDetector(const DetectorSettings& settings, const Model& model)
    : settings_(settings),
      mode_(ResolveBoundMode(settings.bound, model)),
      constant_jacobian_(model.spec().flow_jacobian_constant && model.input_size() == 0),
      inputs_(model.input_size() > 0),
      vertex_sup_(model, mode_) {
  int unknowns = 0;
  for (const Parameter& p : model.spec().alpha) unknowns += p.known ? 0 : 1;
  unknowns_ = unknowns;
  if (constant_jacobian_) {
    const int n = model.state_size(), p = model.alpha_size();
    const auto& rows = model.spec().flow_rows;
    reduced_rows_ = static_cast<int>(rows.size());
    const int cols = mode_ == BoundMode::kHomogeneous ? n + 1 : n;
    g_.resize(reduced_rows_ * cols, p);
    Mat jac(n, n);
    Vec f0(n);
    const Vec zero = Vec::Zero(n);
    for (int i = 0; i < p; ++i) {
      const Vec unit = Vec::Unit(p, i);
      model.FlowJacobian(zero, unit, jac);
      model.Flow(zero, unit, f0);
      for (int r = 0; r < reduced_rows_; ++r) {
        const int row = rows[static_cast<std::size_t>(r)];
        for (int c = 0; c < n; ++c) g_(c * reduced_rows_ + r, i) = jac(row, c);
        if (mode_ == BoundMode::kHomogeneous) g_(n * reduced_rows_ + r, i) = f0[row];
      }
    }
    jvec_.resize(g_.rows());
    gram_ = g_.transpose() * g_;
  }
}

// More than one identified row: the spectral norm of the reshaped Gα.
double PaperDetector::SpectralLinearNormSquared(const double* alpha) {
  const Eigen::Index m = g_.rows();
  jvec_.noalias() = g_ * Eigen::Map<const Vec>(alpha, g_.cols());
  return SpectralNormSquared(Eigen::Map<const Mat>(jvec_.data(), reduced_rows_, m / reduced_rows_));
}

std::unique_ptr<JumpDetector> PaperDetector::CloneWith(const DetectorSettings& settings) const {
  auto copy = std::make_unique<PaperDetector>(*this);
  copy->settings_ = settings;
  return copy;
}

// ClassifyConstant's pair terms and ‖ξ(t−δt)‖ (the previous call's ‖ξ(t)‖ is BoundNorm's sum and root),
// and its rule with the factor r.
bool PaperDetector::FlagsWith(double r, const double* prev, const double* cur, Eigen::Index n, double dt,
                              long flow_updates) const {
  if (flow_updates < unknowns_) return true;  // τ̂0 decided, the same for every r
  const detail::PairTerms pair =
      detail::PairTerms::Of(prev, cur, n, 1.0 / dt, mode_ == BoundMode::kHomogeneous);
  return detail::PaperFlags(pair.d2, 0.5 * r, cached_l2_, pair.cur_norm + BoundNorm(prev, n, mode_));
}

void PaperDetector::Reset() {
  cached_version_ = -1;
  cached_hull_version_ = -1;
  cached_l2_ = 0.0;
  cached_l_ = 0.0;
  last_n_ = 0;
  last_norm_ = 0.0;
}

Decision PaperDetector::Classify(const SampleContext& c) {
  if (constant_jacobian_) {
    return ClassifyConstant(c.prev.data(), c.cur.data(), c.cur.size(), c.dt, c.alpha_hat.data(), c.version,
                            c.flow_updates);
  }
  double prev_norm;
  const detail::PairTerms pair = Prologue(c.prev.data(), c.cur.data(), c.cur.size(), c.dt, &prev_norm);
  Decision d;
  if (WarmUp(pair, c.flow_updates, &d)) return d;
  const double l2 = inputs_ ? PairNormSquared(c) : HullNormSquared(c);
  return detail::PaperDecision(pair, 0.5 * settings_.r, l2, std::sqrt(l2), pair.cur_norm + prev_norm);
}

// L̂² over the vertices of Ĉ (cached per α̂ and hull version) and the current pair.
double PaperDetector::HullNormSquared(const SampleContext& c) {
  const long hull_version = c.flow_set ? c.flow_set->version() : -1;
  if (c.version != cached_version_ || hull_version != cached_hull_version_) {
    double l = 0.0;
    if (c.flow_set && c.flow_set->hull_dimension() >= 0) {
      if (hull_version != cached_hull_version_) vertex_sup_.SetPoints(c.flow_set->vertices());
      l = vertex_sup_.Sup(c.alpha_hat);
    }
    cached_l2_ = l * l;
    cached_version_ = c.version;
    cached_hull_version_ = hull_version;
  }
  pair_.resize(c.cur.size(), 2);
  pair_.col(0) = c.prev;
  pair_.col(1) = c.cur;
  const double l = SupJacobianNorm(*c.model, c.alpha_hat, mode_, pair_, scratch_);
  return std::max(cached_l2_, l * l);
}

// L̂² from the pair alone, each sample at its own time and inputs (the header's rule for inputs).
double PaperDetector::PairNormSquared(const SampleContext& c) {
  const double l = std::max(SupJacobianNorm(*c.model, c.alpha_hat, mode_, c.prev, scratch_, c.at_prev),
                            SupJacobianNorm(*c.model, c.alpha_hat, mode_, c.cur, scratch_, c.at_cur));
  return l * l;
}

DetectorDescriptor PaperDetectorDescriptor() {
  return {.name = "paper",
          .help = "the paper's smoothness bound tau^ = (r/2) L^ (|x(t)| + |x(t-dt)|), tuned by r",
          .options = {"r", "tau0", "bound"},
          .traits = {.statistic = "D", .threshold = "tau_hat"},
          .make = [](const DetectorSettings& s, const Model& m) -> std::unique_ptr<JumpDetector> {
            return std::make_unique<PaperDetector>(s, m);
          }};
}

}  // namespace hysid

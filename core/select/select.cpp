#include "core/select/select.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <stdexcept>

#include <Eigen/Cholesky>
#include <fmt/format.h>

#include "core/model/automaton.hpp"
#include "core/model/regression.hpp"

namespace hysid {
namespace {

// Welford's centred sums of w = [I; z] over one segment and row (the anchor w = 0 first).
struct Running {
  Vec integral, mean;  // running I (p) and mean of w (p + 1)
  double z = 0.0;
  Mat moments;         // (p + 1)²
  long count = 0;
  explicit Running(Eigen::Index p) : integral(Vec::Zero(p)), mean(Vec::Zero(p + 1)), moments(Mat::Zero(p + 1, p + 1)) {}
  void Push() {
    const Eigen::Index p = integral.size();
    Vec w(p + 1);
    w.head(p) = integral;
    w[p] = z;
    ++count;
    const Vec d = w - mean;
    mean += d / double(count);
    moments.noalias() += (1.0 - 1.0 / double(count)) * d * d.transpose();
  }
  RowSums Sums() const {
    const Eigen::Index p = integral.size();
    return {moments.topLeftCorner(p, p), moments.col(p).head(p), moments(p, p), count};
  }
};

struct Segments {
  std::vector<Running> rows;
  FlowSums* out;
  int chain = 0;
  Eigen::Index p;
  Segments(FlowSums* o, std::size_t r, Eigen::Index columns) : out(o), p(columns) { Start(r); }
  void Start(std::size_t r) {
    rows.assign(r, Running(p));
    for (Running& row : rows) row.Push();
  }
  void Close() {
    if (rows.empty() || rows.front().count < 2) return;
    SegmentSums s{chain, {}};
    for (const Running& row : rows) s.rows.push_back(row.Sums());
    out->segments.push_back(std::move(s));
  }
  void Restart() {
    const std::size_t r = rows.size();
    Close();
    Start(r);
  }
};

void CheckSamples(const Model& model, const FlowSamples& s) {
  if (s.y == nullptr || s.gamma == nullptr) throw std::invalid_argument("FlowSamples: y and gamma are required");
  const Eigen::Index K = s.y->cols();
  const auto sized = [&](std::size_t size) { return size == std::size_t(K); };
  if (s.y->rows() != model.state_size() || !sized(s.gamma->size()) ||
      (s.times != nullptr && !s.times->empty() && !sized(s.times->size())) ||
      (s.chain_start != nullptr && !s.chain_start->empty() && !sized(s.chain_start->size())) ||
      (model.input_size() > 0 && (s.inputs == nullptr || s.inputs->cols() != K || s.inputs->rows() != model.input_size()))) {
    throw std::invalid_argument(fmt::format("FlowSamples: sizes disagree ({} states × {} samples, gamma {})",
                                            s.y->rows(), K, s.gamma->size()));
  }
  if ((s.times == nullptr || s.times->empty()) && !(s.dt > 0.0))
    throw std::invalid_argument(fmt::format("FlowSamples::dt = {}: must be > 0 without times", s.dt));
  if (s.modes != nullptr && !s.modes->empty() && !sized(s.modes->size()))
    throw std::invalid_argument(fmt::format("FlowSamples: {} modes for {} samples", s.modes->size(), K));
  if (s.margin < 0) throw std::invalid_argument(fmt::format("FlowSamples::margin = {}: must be >= 0", s.margin));
  if (s.mode < 0 || s.mode >= ModeCount(model.spec()))
    throw std::invalid_argument(fmt::format("FlowSamples::mode = {}: model '{}' has {} mode(s)", s.mode, model.name(),
                                            ModeCount(model.spec())));
}

}  // namespace

bool SelectOptions::IsValid(std::string* error) const {
  const auto fail = [&](const std::string& what) {
    if (error != nullptr) *error = what;
    return false;
  };
  if (thresholds < 1) return fail(fmt::format("SelectOptions::thresholds = {}: must be >= 1", thresholds));
  if (iterations < 1) return fail(fmt::format("SelectOptions::iterations = {}: must be >= 1", iterations));
  if (min_segment < 2) return fail(fmt::format("SelectOptions::min_segment = {}: must be >= 2", min_segment));
  if (folds < 2 && folds != 0)
    return fail(fmt::format("SelectOptions::folds = {}: must be >= 2, or 0 (leave one segment out)", folds));
  if (exhaustive < 0 || exhaustive > 3)
    return fail(fmt::format("SelectOptions::exhaustive = {}: must be in [0, 3]", exhaustive));
  if (!(min_share >= 0.0 && min_share <= 1.0))
    return fail(fmt::format("SelectOptions::min_share = {}: must be in [0, 1]", min_share));
  return true;
}

FlowSums SumFlowSegments(const Model& model, const FlowSamples& s) {
  CheckSamples(model, s);
  RegressionBuilder builder(model);
  const RegressionLayout& layout = builder.flow_layout();
  const auto p = static_cast<Eigen::Index>(layout.unknown.size());
  const auto R = static_cast<Eigen::Index>(layout.rows.size());
  FlowSums out{layout.unknown, {}};
  Segments seg(&out, std::size_t(R), p);
  const Mat& y = *s.y;
  const bool timed = s.times != nullptr && !s.times->empty();
  const bool chained = s.chain_start != nullptr && !s.chain_start->empty();
  const bool moded = s.modes != nullptr && !s.modes->empty();
  // Per sample: within `margin` samples of a mode change (between samples i − 1 and i: i − margin ≤ k < i + margin).
  std::vector<std::uint8_t> near(std::size_t(y.cols()), 0);
  for (Eigen::Index i = 1; moded && s.margin > 0 && i < y.cols(); ++i) {
    if ((*s.modes)[std::size_t(i)] == (*s.modes)[std::size_t(i - 1)]) continue;
    for (Eigen::Index k = std::max<Eigen::Index>(0, i - s.margin); k < std::min<Eigen::Index>(y.cols(), i + s.margin); ++k)
      near[std::size_t(k)] = 1;
  }
  const auto in_mode = [&](Eigen::Index k) {
    return (moded ? (*s.modes)[std::size_t(k)] : 0) == s.mode && near[std::size_t(k)] == 0;
  };
  Mat phi(R, p);
  Vec row(R);
  for (Eigen::Index k = 1; k < y.cols(); ++k) {
    const bool finite = y.col(k).allFinite() && y.col(k - 1).allFinite();
    if ((chained && (*s.chain_start)[std::size_t(k)] != 0) || (*s.gamma)[std::size_t(k)] != 0 || !finite ||
        !in_mode(k - 1) || !in_mode(k)) {
      if (chained && (*s.chain_start)[std::size_t(k)] != 0) seg.chain += 1;
      seg.Restart();
      continue;
    }
    const double h = timed ? (*s.times)[std::size_t(k)] - (*s.times)[std::size_t(k - 1)] : s.dt;
    if (model.input_size() > 0 || moded || s.mode != 0) {
      const double t0 = timed ? (*s.times)[std::size_t(k - 1)] : double(k - 1) * s.dt;
      const double* u0 = model.input_size() > 0 ? s.inputs->col(k - 1).data() : nullptr;
      const double* u1 = model.input_size() > 0 ? s.inputs->col(k).data() : nullptr;
      const Context prev{.t = t0, .u = u0, .mode = s.mode};
      const Context cur{.t = t0 + h, .u = u1, .mode = s.mode};
      builder.Flow(y.col(k - 1), y.col(k), h, phi, row, prev, cur);
    } else {
      builder.Flow(y.col(k - 1), y.col(k), h, phi, row);
    }
    for (Eigen::Index r = 0; r < R; ++r) {
      Running& run = seg.rows[std::size_t(r)];
      run.integral += phi.row(r).transpose();
      run.z += row[r];
      run.Push();
    }
  }
  seg.Close();
  return out;
}

FlowSums SumJumps(const Model& model, const JumpSamples& s) {
  CheckSamples(model, FlowSamples{.y = s.y, .gamma = s.gamma, .dt = s.dt, .times = s.times,
                                  .chain_start = s.chain_start, .inputs = s.inputs});
  const bool sliced = !model.spec().jumps.empty();
  if (sliced && (s.maps == nullptr || s.maps->size() != std::size_t(s.y->cols()) || s.map < 0 ||
                 s.map >= int(model.spec().jumps.size()))) {
    throw std::invalid_argument(fmt::format("JumpSamples: model '{}' has {} [[jump]] maps: give each sample's map "
                                            "({} entries) and a map in [0, {}), not {}",
                                            model.name(), model.spec().jumps.size(), s.y->cols(),
                                            model.spec().jumps.size(), s.map));
  }
  RegressionBuilder builder(model);
  const RegressionLayout& layout = builder.jump_layout();
  const auto p = static_cast<Eigen::Index>(layout.unknown.size());
  const auto R = static_cast<Eigen::Index>(layout.rows.size());
  FlowSums out{layout.unknown, {}, false};
  const Mat& y = *s.y;
  const bool timed = s.times != nullptr && !s.times->empty();
  const bool chained = s.chain_start != nullptr && !s.chain_start->empty();
  int chain = 0;
  Mat psi(R, p);
  Vec row(R);
  for (Eigen::Index k = 1; k < y.cols(); ++k) {
    if (chained && (*s.chain_start)[std::size_t(k)] != 0) {
      ++chain;
      continue;
    }
    if ((*s.gamma)[std::size_t(k)] == 0 || !y.col(k).allFinite() || !y.col(k - 1).allFinite()) continue;
    if (sliced && (*s.maps)[std::size_t(k)] != s.map) continue;
    const Context prev{.t = timed ? (*s.times)[std::size_t(k - 1)] : double(k - 1) * s.dt,
                       .u = model.input_size() > 0 ? s.inputs->col(k - 1).data() : nullptr,
                       .map = sliced ? s.map : 0};
    builder.Jump(y.col(k - 1), y.col(k), psi, row, prev);
    SegmentSums group{chain, {}};
    for (Eigen::Index r = 0; r < R; ++r) {
      const Vec a = psi.row(r).transpose();
      group.rows.push_back({a * a.transpose(), a * row[r], row[r] * row[r], 1});
    }
    out.segments.push_back(std::move(group));
  }
  return out;
}

std::vector<int> ColumnsInUse(const FlowSums& sums) {
  std::vector<int> out;
  for (std::size_t j = 0; j < sums.columns.size(); ++j) {
    bool used = false;
    for (const SegmentSums& seg : sums.segments) {
      for (const RowSums& r : seg.rows) used = used || r.gram(Eigen::Index(j), Eigen::Index(j)) != 0.0;
    }
    if (used) out.push_back(static_cast<int>(j));
  }
  return out;
}

FlowSums KeepColumns(const FlowSums& sums, const std::vector<int>& keep) {
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (keep[i] < 0 || std::size_t(keep[i]) >= sums.columns.size() || (i > 0 && keep[i] <= keep[i - 1]))
      throw std::invalid_argument(fmt::format("KeepColumns: position {} of {} columns (ascending required)", keep[i],
                                              sums.columns.size()));
  }
  const auto k = static_cast<Eigen::Index>(keep.size());
  const std::size_t R = sums.segments.empty() ? 0 : sums.segments.front().rows.size();
  std::vector<bool> row_used(R, false);
  for (const SegmentSums& seg : sums.segments) {
    for (std::size_t r = 0; r < R; ++r) {
      for (int j : keep) row_used[r] = row_used[r] || seg.rows[r].gram(j, j) != 0.0;
    }
  }
  FlowSums out;
  out.centred = sums.centred;
  for (int j : keep) out.columns.push_back(sums.columns[std::size_t(j)]);
  for (const SegmentSums& seg : sums.segments) {
    SegmentSums s{seg.chain, {}};
    for (std::size_t r = 0; r < R; ++r) {
      if (!row_used[r]) continue;
      const RowSums& in = seg.rows[r];
      RowSums rs{Mat(k, k), Vec(k), in.square, in.count};
      for (Eigen::Index a = 0; a < k; ++a) {
        rs.cross[a] = in.cross[keep[std::size_t(a)]];
        for (Eigen::Index b = 0; b < k; ++b) rs.gram(a, b) = in.gram(keep[std::size_t(a)], keep[std::size_t(b)]);
      }
      s.rows.push_back(std::move(rs));
    }
    out.segments.push_back(std::move(s));
  }
  return out;
}

namespace {

// Normal equations of one row summed over the segments (each `multiplicity` times), rows N and offsets.
struct Normal {
  Mat gram;
  Vec cross;
  double square = 0.0;
  double rows = 0.0, offsets = 0.0;
};

// fold >= 0: only the segments i with i % folds == fold. Centred sums: one offset per segment and row,
// segments of fewer than min_segment samples left out.
std::vector<Normal> RowTotals(const FlowSums& sums, const std::vector<int>& multiplicity, int min_segment,
                              int fold = -1, int folds = 1) {
  const auto p = static_cast<Eigen::Index>(sums.columns.size());
  const std::size_t R = sums.segments.empty() ? 0 : sums.segments.front().rows.size();
  std::vector<Normal> out(R, Normal{Mat::Zero(p, p), Vec::Zero(p)});
  for (std::size_t i = 0; i < sums.segments.size(); ++i) {
    const double m = multiplicity.empty() ? 1.0 : double(multiplicity[i]);
    if (m == 0.0 || (fold >= 0 && int(i % std::size_t(folds)) != fold)) continue;
    for (std::size_t r = 0; r < R; ++r) {
      const RowSums& rs = sums.segments[i].rows[r];
      if (sums.centred && rs.count < min_segment) continue;
      out[r].gram += m * rs.gram;
      out[r].cross += m * rs.cross;
      out[r].square += m * rs.square;
      out[r].rows += m * double(rs.count);
      out[r].offsets += sums.centred ? m : 0.0;
    }
  }
  return out;
}

struct Fit {
  bool ok = false;
  Vec alpha;         // on the support's columns, in support order
  Vec inverse_diag;  // diag of G_SS⁻¹
  double rss = 0.0;
};

// Least squares on the columns `support` of the normal equations, equilibrated by √diag(G).
Fit Solve(const Normal& ne, const std::vector<int>& support) {
  const auto k = static_cast<Eigen::Index>(support.size());
  Fit fit;
  if (k == 0) {
    fit.ok = true;
    fit.rss = ne.square;
    return fit;
  }
  Mat a(k, k);
  Vec b(k), d(k);
  for (Eigen::Index i = 0; i < k; ++i) {
    const double g = ne.gram(support[std::size_t(i)], support[std::size_t(i)]);
    if (!(g > 0.0) || !std::isfinite(g)) return fit;
    d[i] = 1.0 / std::sqrt(g);
  }
  for (Eigen::Index i = 0; i < k; ++i) {
    b[i] = d[i] * ne.cross[support[std::size_t(i)]];
    for (Eigen::Index j = 0; j < k; ++j) a(i, j) = d[i] * d[j] * ne.gram(support[std::size_t(i)], support[std::size_t(j)]);
  }
  const Eigen::LDLT<Mat> ldlt(a);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
      ldlt.vectorD().minCoeff() < 1e-13 * ldlt.vectorD().maxCoeff()) {
    return fit;  // the columns are (numerically) dependent: no unique fit on this support
  }
  const Vec beta = ldlt.solve(b);
  fit.alpha = d.cwiseProduct(beta);
  fit.inverse_diag = d.cwiseAbs2().cwiseProduct(ldlt.solve(Mat::Identity(k, k)).diagonal());
  fit.rss = std::max(ne.square - beta.dot(b), 1e-300);
  fit.ok = std::isfinite(fit.rss);
  return fit;
}

std::vector<int> Indices(const std::vector<bool>& support) {
  std::vector<int> out;
  for (std::size_t j = 0; j < support.size(); ++j)
    if (support[j]) out.push_back(static_cast<int>(j));
  return out;
}

// STLSQ from the full support at threshold λ on the relative coefficients |α_j|·√G_jj/√s.
std::vector<bool> Thresholded(const Normal& ne, const std::vector<bool>& selectable, double lambda, int iterations) {
  std::vector<bool> support(selectable.size(), true);
  for (int it = 0; it < iterations; ++it) {
    const std::vector<int> idx = Indices(support);
    const Fit fit = Solve(ne, idx);
    if (!fit.ok) return {};
    bool changed = false;
    for (std::size_t i = 0; i < idx.size(); ++i) {
      const int j = idx[i];
      const double rel = std::abs(fit.alpha[Eigen::Index(i)]) * std::sqrt(ne.gram(j, j) / ne.square);
      if (selectable[std::size_t(j)] && rel < lambda) {
        support[std::size_t(j)] = false;
        changed = true;
      }
    }
    if (!changed) break;
  }
  return support;
}

// Backward elimination: every support from the full one down, dropping the selectable column of least |t|.
std::vector<std::vector<bool>> Backward(const Normal& ne, const std::vector<bool>& selectable) {
  std::vector<std::vector<bool>> out;
  std::vector<bool> support(selectable.size(), true);
  for (;;) {
    const std::vector<int> idx = Indices(support);
    const Fit fit = Solve(ne, idx);
    if (fit.ok) out.push_back(support);
    int drop = -1;
    double least = std::numeric_limits<double>::infinity();
    for (std::size_t i = 0; i < idx.size(); ++i) {
      if (!selectable[std::size_t(idx[i])]) continue;
      // Without a fit (dependent columns) the column of least diagonal is dropped first.
      const double t = fit.ok ? std::abs(fit.alpha[Eigen::Index(i)]) / std::sqrt(fit.inverse_diag[Eigen::Index(i)])
                              : ne.gram(idx[i], idx[i]);
      if (t < least) {
        least = t;
        drop = idx[i];
      }
    }
    if (drop < 0) break;
    support[std::size_t(drop)] = false;
  }
  return out;
}

// Forward selection: from the columns that are not selectable, every support that adds the
// selectable column whose fit leaves the least residual sum of squares, up to every column (or until
// no column can be added with independent columns). Unlike the two paths above it does not start
// from the full fit, whose coefficients on nearly dependent columns are large and arbitrary.
std::vector<std::vector<bool>> Forward(const Normal& ne, const std::vector<bool>& selectable) {
  std::vector<std::vector<bool>> out;
  std::vector<bool> support(selectable.size());
  for (std::size_t j = 0; j < selectable.size(); ++j) support[j] = !selectable[j];
  for (;;) {
    int add = -1;
    double least = std::numeric_limits<double>::infinity();
    for (std::size_t j = 0; j < selectable.size(); ++j) {
      if (support[j]) continue;
      support[j] = true;
      const Fit fit = Solve(ne, Indices(support));
      support[j] = false;
      if (fit.ok && fit.rss < least) {
        least = fit.rss;
        add = static_cast<int>(j);
      }
    }
    if (add < 0) break;
    support[std::size_t(add)] = true;
    out.push_back(support);
  }
  return out;
}

// Every support of at most `size` selectable columns (and the columns that are not selectable).
std::vector<std::vector<bool>> Small(const std::vector<bool>& selectable, int size) {
  std::vector<std::vector<bool>> out;
  std::vector<bool> base(selectable.size());
  for (std::size_t j = 0; j < selectable.size(); ++j) base[j] = !selectable[j];
  const std::vector<int> free = Indices(selectable);
  std::vector<std::vector<bool>> level = {base};
  for (int k = 1; k <= size; ++k) {
    std::vector<std::vector<bool>> next;
    for (const std::vector<bool>& s : level) {
      // Add only columns after the last added, so that each support is made once.
      int last = -1;
      for (int j : free) if (s[std::size_t(j)]) last = j;
      for (int j : free) {
        if (j <= last) continue;
        std::vector<bool> t = s;
        t[std::size_t(j)] = true;
        next.push_back(std::move(t));
      }
    }
    out.insert(out.end(), next.begin(), next.end());
    level = std::move(next);
  }
  return out;
}

// w_r = 1/σ̂_r² from the full support's residuals per row (one row: 1).
std::vector<double> RowWeights(const std::vector<Normal>& rows, const std::vector<bool>& all) {
  std::vector<double> w(rows.size(), 1.0);
  if (rows.size() == 1) return w;
  for (std::size_t r = 0; r < rows.size(); ++r) {
    const Fit fit = Solve(rows[r], Indices(all));
    const double dof = rows[r].rows - rows[r].offsets - double(fit.alpha.size());
    if (fit.ok && dof > 0.0 && fit.rss > 0.0) w[r] = dof / fit.rss;
  }
  return w;
}

// Σ_r w_r NE_r.
Normal Combined(const std::vector<Normal>& rows, const std::vector<double>& w) {
  Normal out{Mat::Zero(rows.front().gram.rows(), rows.front().gram.cols()), Vec::Zero(rows.front().cross.size())};
  for (std::size_t r = 0; r < rows.size(); ++r) {
    out.gram += w[r] * rows[r].gram;
    out.cross += w[r] * rows[r].cross;
    out.square += w[r] * rows[r].square;
    out.rows += rows[r].rows;
    out.offsets += rows[r].offsets;
  }
  return out;
}

// The residual sum of squares of α (on `idx`) on the held-out normal equations.
double HeldOutRss(const Normal& test, const std::vector<int>& idx, const Vec& alpha) {
  double rss = test.square;
  for (std::size_t i = 0; i < idx.size(); ++i) {
    rss -= 2.0 * alpha[Eigen::Index(i)] * test.cross[idx[i]];
    for (std::size_t j = 0; j < idx.size(); ++j) rss += alpha[Eigen::Index(i)] * alpha[Eigen::Index(j)] * test.gram(idx[i], idx[j]);
  }
  return rss;
}

// K-fold cross-validation over the segments (segment i in fold i mod K): per support the held-out
// mean square and its standard error over the folds.
struct CrossValidation {
  std::vector<Normal> train, test;
  std::pair<double, double> Score(const std::vector<int>& idx) const {
    std::vector<double> per_fold;
    double rss = 0.0, rows = 0.0;
    for (std::size_t f = 0; f < test.size(); ++f) {
      const double n = test[f].rows - test[f].offsets;
      if (!(n > 0.0)) continue;
      const Fit fit = Solve(train[f], idx);
      if (!fit.ok) return {std::numeric_limits<double>::infinity(), 0.0};
      const double e = HeldOutRss(test[f], idx, fit.alpha.size() ? fit.alpha : Vec());
      rss += e;
      rows += n;
      per_fold.push_back(e / n);
    }
    if (per_fold.size() < 2) return {std::numeric_limits<double>::infinity(), 0.0};
    double mean = 0.0, var = 0.0;
    for (double e : per_fold) mean += e / double(per_fold.size());
    for (double e : per_fold) var += (e - mean) * (e - mean) / double(per_fold.size() - 1);
    return {rss / rows, std::sqrt(var / double(per_fold.size()))};
  }
};

CrossValidation MakeFolds(const FlowSums& sums, const std::vector<int>& multiplicity, const SelectOptions& o,
                          const std::vector<double>& w, const Normal& total) {
  CrossValidation cv;
  const int folds = o.folds > 0 ? o.folds : static_cast<int>(sums.segments.size());
  for (int f = 0; f < folds; ++f) {
    Normal test = Combined(RowTotals(sums, multiplicity, o.min_segment, f, folds), w);
    Normal train = total;
    train.gram -= test.gram;
    train.cross -= test.cross;
    train.square -= test.square;
    train.rows -= test.rows;
    train.offsets -= test.offsets;
    cv.test.push_back(std::move(test));
    cv.train.push_back(std::move(train));
  }
  return cv;
}

}  // namespace

Selection SelectTerms(const FlowSums& sums, const std::vector<bool>& selectable, const SelectOptions& options,
                      const std::vector<int>& multiplicity) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  const std::size_t p = sums.columns.size();
  if (selectable.size() != p) {
    throw std::invalid_argument(fmt::format("SelectTerms: {} selectable flags for {} columns", selectable.size(), p));
  }
  if (!multiplicity.empty() && multiplicity.size() != sums.segments.size())
    throw std::invalid_argument("SelectTerms: one multiplicity per segment");
  Selection out;
  out.chosen.assign(p, false);
  out.estimate = Vec::Zero(Eigen::Index(p));
  const std::vector<Normal> rows = RowTotals(sums, multiplicity, options.min_segment);
  if (rows.empty()) {
    out.reason = sums.centred ? "no flow segment" : "no jump";
    return out;
  }
  const std::vector<bool> all(p, true);
  const std::vector<double> weights = RowWeights(rows, all);
  const Normal ne = Combined(rows, weights);
  const double N = ne.rows - ne.offsets;
  out.rows = static_cast<long>(N);
  if (!(N > double(p) + 1.0) || !(ne.square > 0.0)) {
    out.reason = sums.centred ? fmt::format("{} integral rows (less one offset per segment) for {} unknowns", N, p)
                              : fmt::format("{} jump rows for {} unknowns", N, p);
    return out;
  }
  std::vector<std::vector<bool>> supports = Backward(ne, selectable);
  for (std::vector<bool>& f : Forward(ne, selectable)) supports.push_back(std::move(f));
  for (std::vector<bool>& f : Small(selectable, options.exhaustive)) supports.push_back(std::move(f));
  const Fit full = Solve(ne, Indices(all));
  if (full.ok) {
    double lo = std::numeric_limits<double>::infinity(), hi = 0.0;
    for (std::size_t j = 0; j < p; ++j) {
      if (!selectable[j]) continue;
      const double rel = std::abs(full.alpha[Eigen::Index(j)]) * std::sqrt(ne.gram(Eigen::Index(j), Eigen::Index(j)) / ne.square);
      if (rel > 0.0) {
        lo = std::min(lo, rel);
        hi = std::max(hi, rel);
      }
    }
    for (int i = 0; hi > 0.0 && i < options.thresholds; ++i) {
      const double f = options.thresholds == 1 ? 1.0 : double(i) / double(options.thresholds - 1);
      const double lambda = std::exp(std::log(lo * 0.999) + f * (std::log(hi * 1.001) - std::log(lo * 0.999)));
      if (std::vector<bool> s = Thresholded(ne, selectable, lambda, options.iterations); !s.empty())
        supports.push_back(std::move(s));
    }
  }
  // Per support: BIC, and the cross-validated mean square with its standard error.
  struct Score {
    double bic, cv, se;
    std::size_t size;
  };
  std::map<std::vector<bool>, Score> scores;
  const bool by_cv = options.rule == SelectionRule::kCrossValidation;
  const CrossValidation folds = by_cv ? MakeFolds(sums, multiplicity, options, weights, ne) : CrossValidation{};
  for (const std::vector<bool>& s : supports) {
    if (scores.contains(s)) continue;
    const std::vector<int> idx = Indices(s);
    const Fit fit = Solve(ne, idx);
    if (!fit.ok) continue;
    const auto [cv, se] = by_cv ? folds.Score(idx) : std::pair{0.0, 0.0};
    scores[s] = {N * std::log(fit.rss / N) + double(idx.size()) * std::log(N), cv, se, idx.size()};
  }
  if (scores.empty()) {
    out.reason = "no support with independent columns";
    return out;
  }
  out.supports = static_cast<int>(scores.size());
  // BIC: the least. Cross-validation: the fewest columns within one standard error of the least
  // held-out mean square (ties: the lesser mean square).
  const auto key = [&](const Score& s) { return by_cv ? s.cv : s.bic; };
  const Score* best = nullptr;
  for (const auto& [s, score] : scores) {
    if (best == nullptr || key(score) < key(*best)) best = &score;
  }
  const double limit = by_cv ? best->cv + best->se : best->bic;
  const std::vector<bool>* chosen = nullptr;
  for (const auto& [s, score] : scores) {
    if (key(score) > limit) continue;
    const Score* c = chosen ? &scores.at(*chosen) : nullptr;
    if (c == nullptr || score.size < c->size || (score.size == c->size && key(score) < key(*c))) chosen = &s;
  }
  out.chosen = *chosen;
  out.bic = scores.at(out.chosen).bic;
  out.cv = scores.at(out.chosen).cv;
  out.runner_up_bic = std::numeric_limits<double>::infinity();
  for (const auto& [s, score] : scores) {
    if (s != out.chosen && score.bic < out.runner_up_bic) {
      out.runner_up_bic = score.bic;
      out.runner_up = s;
    }
  }
  const std::vector<int> idx = Indices(out.chosen);
  const Fit fit = Solve(ne, idx);
  for (std::size_t i = 0; i < idx.size(); ++i) out.estimate[idx[i]] = fit.alpha[Eigen::Index(i)];
  out.ok = true;
  return out;
}

BootstrapResult BootstrapSelection(const FlowSums& sums, const std::vector<bool>& selectable,
                                   const SelectOptions& options, int draws, std::uint64_t seed,
                                   const std::vector<bool>& reference) {
  if (draws < 1) throw std::invalid_argument(fmt::format("BootstrapSelection: draws = {}: must be >= 1", draws));
  BootstrapResult out;
  out.frequency = Vec::Zero(Eigen::Index(sums.columns.size()));
  const auto S = static_cast<int>(sums.segments.size());
  if (S == 0) return out;
  std::vector<int> multiplicity(static_cast<std::size_t>(S), 0);
  for (int d = 0; d < draws; ++d) {
    std::seed_seq seq{std::uint32_t(seed), std::uint32_t(seed >> 32), std::uint32_t(d)};
    std::mt19937_64 rng(seq);
    std::uniform_int_distribution<int> pick(0, S - 1);
    std::fill(multiplicity.begin(), multiplicity.end(), 0);
    for (int i = 0; i < S; ++i) ++multiplicity[std::size_t(pick(rng))];
    const Selection s = SelectTerms(sums, selectable, options, multiplicity);
    if (!s.ok) continue;
    ++out.draws;
    for (std::size_t j = 0; j < s.chosen.size(); ++j) out.frequency[Eigen::Index(j)] += s.chosen[j] ? 1.0 : 0.0;
    if (s.chosen == reference) ++out.support_matches;
  }
  out.frequency /= double(draws);
  return out;
}

Selection KeepStable(const FlowSums& sums, const std::vector<bool>& selectable, const Selection& selection,
                     const BootstrapResult& bootstrap, const SelectOptions& options) {
  std::string error;
  if (!options.IsValid(&error)) throw std::invalid_argument(error);
  const std::size_t p = sums.columns.size();
  if (selectable.size() != p || (selection.ok && selection.chosen.size() != p) ||
      (bootstrap.draws > 0 && static_cast<std::size_t>(bootstrap.frequency.size()) != p)) {
    throw std::invalid_argument(fmt::format("KeepStable: {} columns, {} selectable flags, {} chosen, {} frequencies",
                                            p, selectable.size(), selection.chosen.size(),
                                            bootstrap.frequency.size()));
  }
  if (!selection.ok || bootstrap.draws == 0) return selection;
  std::vector<bool> kept = selection.chosen;
  for (std::size_t j = 0; j < p; ++j) {
    if (selectable[j] && kept[j] && bootstrap.frequency[Eigen::Index(j)] < options.min_share) kept[j] = false;
  }
  if (kept == selection.chosen) return selection;
  const std::vector<Normal> rows = RowTotals(sums, {}, options.min_segment);
  const std::vector<double> weights = RowWeights(rows, std::vector<bool>(p, true));
  const Normal ne = Combined(rows, weights);
  const std::vector<int> idx = Indices(kept);
  const Fit fit = Solve(ne, idx);
  if (!fit.ok) return selection;
  Selection out = selection;
  out.chosen = kept;
  out.estimate = Vec::Zero(Eigen::Index(p));
  for (std::size_t i = 0; i < idx.size(); ++i) out.estimate[idx[i]] = fit.alpha[Eigen::Index(i)];
  const double N = ne.rows - ne.offsets;
  out.bic = N * std::log(fit.rss / N) + double(idx.size()) * std::log(N);
  out.runner_up = selection.chosen;  // the other support named beside it: the cross-validated one
  out.runner_up_bic = selection.bic;
  if (options.rule == SelectionRule::kCrossValidation) {
    out.cv = MakeFolds(sums, {}, options, weights, ne).Score(idx).first;
  }
  return out;
}

}  // namespace hysid

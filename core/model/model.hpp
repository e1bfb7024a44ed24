// Hybrid models ξ' = φ(ξ)α on C, ξ+ = ψ(ξ)β on D (paper eq. 1 and Assumption 1).
//
// A model is a plain struct satisfying the HybridModel concept below; Model is a type-erased value
// that holds one together with the current true parameter values α and β. Copies are cheap (the
// struct is shared, immutable) and safe to use from several threads.
#pragma once

#include <concepts>
#include <limits>
#include <memory>
#include <string>
#include <string_view>
#include <type_traits>
#include <utility>
#include <vector>

#include <Eigen/Core>

#include "core/model/context.hpp"
#include "core/model/jump_map.hpp"

namespace hysid {

using Vec = Eigen::VectorXd;
using Mat = Eigen::MatrixXd;
using VecRef = Eigen::Ref<Eigen::VectorXd>;
using ConstVecRef = Eigen::Ref<const Eigen::VectorXd>;
using MatRef = Eigen::Ref<Eigen::MatrixXd>;
using ConstMatRef = Eigen::Ref<const Eigen::MatrixXd>;

// Sets the R × C matrix m from its entries listed row by row: what a comma initialiser does, without
// its per-entry bookkeeping on a Ref (models' φ, ψ and Jacobians are evaluated every sample).
template <int R, int C>
inline void SetRowMajor(MatRef m, const double (&entries)[R * C]) {
  for (int i = 0; i < R; ++i) {
    for (int j = 0; j < C; ++j) m(i, j) = entries[i * C + j];
  }
}

// Direction in which a guard function h(ξ) must cross zero for the crossing to reach D.
enum class Crossing { kFalling, kRising, kBoth };

struct Guard {
  std::string name;
  Crossing direction = Crossing::kFalling;
};

// One entry of α, β or γ. `known` marks a constant of the model structure (the 1 in ξ1' = 1·ξ2); it is
// not identified and cannot be set from the command line. [lower, upper] bounds the value (checked
// when the model is built and by SetParameter; lower < upper, the value inside).
struct Parameter {
  std::string name;
  double value = 0.0;
  bool known = false;
  std::string description;
  double lower = -std::numeric_limits<double>::infinity();
  double upper = std::numeric_limits<double>::infinity();
};

// A candidate term of a flow row (a model file's [flow] or [[flow]] candidates): the α entry whose φ
// column is the expression `term` in row `row` of mode `mode`'s φ and 0 elsewhere (every other mode's φ
// included), its coefficient to be selected from the data of that mode.
struct CandidateTerm {
  int alpha = 0;
  int row = 0;
  std::string term;
  int mode = 0;
};

// A candidate term of a jump row (a model file's [jump] or [[jump]] candidates): the β entry whose ψ
// column is the expression `term` (of the pre-jump state) in row `row` and 0 elsewhere, its
// coefficient to be selected from the detected jumps (of map `map`'s, within its β slice).
struct JumpCandidateTerm {
  int beta = 0;
  int row = 0;
  std::string term;
  int map = -1;  // index into ModelSpec::jumps; −1: the one [jump]
};

struct ModelSpec {
  std::string name;
  std::string description;
  std::vector<std::string> state_names;  // n entries
  std::vector<Parameter> alpha;          // flow parameters: columns of φ
  std::vector<Parameter> beta;           // jump parameters: columns of ψ
  // State components whose rows carry unknown parameters (reduced-order identification, §4.3).
  std::vector<int> flow_rows;
  std::vector<int> jump_rows;
  std::vector<Guard> guards;
  // true when ∂(φ(ξ)α)/∂ξ does not depend on ξ (then sup over Ĉ is one evaluation).
  bool flow_jacobian_constant = false;
  std::vector<double> default_x0;
  double default_t_end = 10.0;
  double default_dt = 1e-3;
  // Human-readable equations, one per line (flow, jump, guards, sets), for `hysid models --show`.
  std::string equations = {};
  // State indices the data holds, ascending or in the file's order, no duplicates; empty: every state.
  std::vector<int> measured = {};
  // Names of the measured inputs u (Context::u holds their values), default none.
  std::vector<std::string> inputs = {};
  // Per input an expression of t that simulate uses when no input data is given (model files; may be
  // empty, or hold empty strings).
  std::vector<std::string> input_defaults = {};
  // γ: parameters of the guards, projections and sets (usable in φ and ψ too); Context::gamma.
  std::vector<Parameter> guard_params = {};
  // A hybrid automaton (core/model/automaton.hpp): the discrete modes q (empty: one unnamed mode; φ of
  // mode q is Phi with Context::mode = q, every mode over the one α) and the jump maps (empty: one map
  // that every guard triggers, ψ over all of β). With maps, every guard triggers at least one map and a
  // (mode, guard) pair at most one; only the guards of maps leaving the current mode are armed.
  std::vector<std::string> modes = {};
  std::vector<JumpMap> jumps = {};
  int default_mode = 0;  // q0 when none is given
  // Candidate terms among α (empty: none); each is an unknown α entry.
  std::vector<CandidateTerm> candidates = {};
  // Candidate terms among β (empty: none); each is an unknown β entry.
  std::vector<JumpCandidateTerm> jump_candidates = {};
};

// Which member functions a model struct must provide. ξ has size n = spec.state_names.size().
// Either the x-only forms (the paper's class: no inputs, no guard parameters) ...
template <class M>
concept XOnlyModel = requires(const M& m, ConstVecRef x, MatRef out_mat, VecRef out_vec) {
  m.Phi(x, out_mat);     // φ(ξ), n × |α|
  m.Psi(x, out_mat);     // ψ(ξ), n × |β|
  m.Guards(x, out_vec);  // h_i(ξ), one per spec.guards entry
  { m.InFlowSet(x) } -> std::convertible_to<bool>;
  { m.InJumpSet(x) } -> std::convertible_to<bool>;
};

// ... or the context forms, evaluated at (ξ, t, u, γ). Optional members take the context in the same
// place: PhiColumns(x, count, ctx, phi), PhiRowColumns(row, x, count, ctx, phi), ProjectOntoGuard(i, ctx,
// x), DistanceToJumpSet(x, ctx).
template <class M>
concept ContextModel = requires(const M& m, ConstVecRef x, const Context& ctx, MatRef out_mat, VecRef out_vec) {
  m.Phi(x, ctx, out_mat);
  m.Psi(x, ctx, out_mat);
  m.Guards(x, ctx, out_vec);
  { m.InFlowSet(x, ctx) } -> std::convertible_to<bool>;
  { m.InJumpSet(x, ctx) } -> std::convertible_to<bool>;
};

template <class M>
concept HybridModel = std::copy_constructible<M> && (XOnlyModel<M> || ContextModel<M>) && requires(const M& m) {
  { m.Spec() } -> std::convertible_to<ModelSpec>;
};

template <class M>
concept HasFlowJacobian = requires(const M& m, ConstVecRef x, ConstVecRef alpha, MatRef jac) {
  m.FlowJacobian(x, alpha, jac);
};

// Optional: the Euclidean distance from ξ to the true jump set D (0 on D). Used by the set metrics
// (core/sets/set_metrics.hpp); models without it give NaN set metrics.
template <class M>
concept HasJumpSetDistance = requires(const M& m, ConstVecRef x) {
  { m.DistanceToJumpSet(x) } -> std::convertible_to<double>;
};

// Optional: φ at `count` states in one call (same layout as Model::PhiColumns). For structs whose
// per-call set-up is worth amortising over a block (the model-file evaluator).
template <class M>
concept HasPhiColumns = requires(const M& m, const double* x, Eigen::Index count, double* phi) {
  m.PhiColumns(x, count, phi);
};

// Optional: row `row` of φ alone at `count` states (Model::PhiRowColumns). For structs that can
// evaluate one row for less than all of φ (the model-file evaluator: that row's expressions).
template <class M>
concept HasPhiRowColumns = requires(const M& m, int row, const double* x, Eigen::Index count, double* phi) {
  m.PhiRowColumns(row, x, count, phi);
};

template <class M>
concept HasGuardProjection = requires(const M& m, int i, VecRef x) {
  m.ProjectOntoGuard(i, x);
};

template <class M>
concept HasContextPhiColumns = requires(const M& m, const double* x, Eigen::Index count, const Context& ctx,
                                        double* phi) {
  m.PhiColumns(x, count, ctx, phi);
};
template <class M>
concept HasContextPhiRowColumns = requires(const M& m, int row, const double* x, Eigen::Index count,
                                           const Context& ctx, double* phi) {
  m.PhiRowColumns(row, x, count, ctx, phi);
};
template <class M>
concept HasContextGuardProjection = requires(const M& m, int i, const Context& ctx, VecRef x) {
  m.ProjectOntoGuard(i, ctx, x);
};
template <class M>
concept HasContextJumpSetDistance = requires(const M& m, ConstVecRef x, const Context& ctx) {
  { m.DistanceToJumpSet(x, ctx) } -> std::convertible_to<double>;
};

class Model {
 public:
  // Not for Model itself: checking HybridModel<Model> would recurse into this constructor (clang 14
  // rejects that; g++ 12 accepts it).
  template <class M>
  requires(!std::is_same_v<std::remove_cvref_t<M>, Model>) && HybridModel<M> explicit Model(M model)
      : impl_(std::make_shared<const Impl<M>>(std::move(model))) {
    Init();
  }

  const ModelSpec& spec() const { return spec_; }
  const std::string& name() const { return spec_.name; }
  int state_size() const { return static_cast<int>(spec_.state_names.size()); }
  int alpha_size() const { return static_cast<int>(alpha_.size()); }
  int beta_size() const { return static_cast<int>(beta_.size()); }
  int gamma_size() const { return static_cast<int>(gamma_.size()); }
  int input_size() const { return static_cast<int>(spec_.inputs.size()); }
  int guard_count() const { return static_cast<int>(spec_.guards.size()); }

  // True parameter values (defaults from the spec unless set).
  const Vec& alpha() const { return alpha_; }
  const Vec& beta() const { return beta_; }
  const Vec& gamma() const { return gamma_; }
  // Sets an unknown parameter of α, β or γ by name. Throws std::invalid_argument naming the parameter
  // when it does not exist, is a known constant, or `value` is not finite or outside its bounds.
  void SetParameter(std::string_view name, double value);
  // Parses "name=value". Same errors as SetParameter, plus malformed text.
  void SetParameter(std::string_view assignment);
  // Replaces the bounds [lower, upper] of an unknown parameter of α, β or γ (infinite ends allowed).
  // Throws std::invalid_argument naming the parameter when it does not exist, is a known constant,
  // lower < upper does not hold, or its value lies outside [lower, upper].
  void SetBounds(std::string_view name, double lower, double upper);

  // Every evaluation has an x-only form (t = 0, no inputs, the model's own γ) and a form with a
  // Context. A model with inputs evaluated without ctx.u throws std::logic_error (a programming error).
  void Phi(const ConstVecRef& x, MatRef phi) const {
    if (contextual_) return impl_->Phi(x, Resolve({}), phi);
    impl_->Phi(x, phi);
  }
  void Phi(const ConstVecRef& x, MatRef phi, const Context& ctx) const { impl_->Phi(x, Resolve(ctx), phi); }
  // φ at `count` states with one call (the struct's Phi inlined in the loop): state k is
  // x[k·n .. k·n + n) and its n × |α| φ goes, column-major, to phi + k·n·|α|. For paths that know
  // their samples ahead (RegressionBuilder::FlowRows). One context for all `count` states.
  void PhiColumns(const double* x, Eigen::Index count, double* phi) const {
    if (contextual_) return PhiColumns(x, count, phi, {});
    impl_->PhiColumns(x, count, state_size(), alpha_size(), phi);
  }
  void PhiColumns(const double* x, Eigen::Index count, double* phi, const Context& ctx) const {
    impl_->PhiColumns(x, count, state_size(), alpha_size(), Resolve(ctx), phi);
  }
  // Row `row` of φ at `count` states, in PhiColumns' layout: φ(row, c) of state k for every column c
  // at phi + k·n·|α| + c·n + row; the other entries of each n × |α| block may be left as they were.
  // For paths that read one row (RegressionBuilder::FlowRows): a struct with PhiRowColumns evaluates
  // that row alone (a model file: that row's expressions; the values must be its PhiColumns' bit for
  // bit), any other all of φ (PhiColumns). 0 ≤ row < n is the caller's to keep.
  void PhiRowColumns(int row, const double* x, Eigen::Index count, double* phi) const {
    if (contextual_) return PhiRowColumns(row, x, count, phi, {});
    impl_->PhiRowColumns(row, x, count, state_size(), alpha_size(), phi);
  }
  void PhiRowColumns(int row, const double* x, Eigen::Index count, double* phi, const Context& ctx) const {
    impl_->PhiRowColumns(row, x, count, state_size(), alpha_size(), Resolve(ctx), phi);
  }
  void Psi(const ConstVecRef& x, MatRef psi) const {
    if (contextual_) return impl_->Psi(x, Resolve({}), psi);
    impl_->Psi(x, psi);
  }
  void Psi(const ConstVecRef& x, MatRef psi, const Context& ctx) const { impl_->Psi(x, Resolve(ctx), psi); }
  // The guards, projections and sets take the resolved context in both forms: they may read α and β.
  void Guards(const ConstVecRef& x, VecRef h) const { impl_->Guards(x, Resolve({}), h); }
  void Guards(const ConstVecRef& x, VecRef h, const Context& ctx) const { impl_->Guards(x, Resolve(ctx), h); }
  bool InFlowSet(const ConstVecRef& x) const { return impl_->InFlowSet(x, Resolve({})); }
  bool InFlowSet(const ConstVecRef& x, const Context& ctx) const { return impl_->InFlowSet(x, Resolve(ctx)); }
  bool InJumpSet(const ConstVecRef& x) const { return impl_->InJumpSet(x, Resolve({})); }
  bool InJumpSet(const ConstVecRef& x, const Context& ctx) const { return impl_->InJumpSet(x, Resolve(ctx)); }
  // Puts x exactly on guard i when the struct knows how; otherwise leaves x unchanged (the
  // simulator's direction filter then keeps the guard from firing again).
  void ProjectOntoGuard(int i, VecRef x) const { impl_->ProjectOntoGuard(i, Resolve({}), x); }
  void ProjectOntoGuard(int i, VecRef x, const Context& ctx) const {
    impl_->ProjectOntoGuard(i, Resolve(ctx), x);
  }
  // Euclidean distance from x to D when the struct provides DistanceToJumpSet, else NaN.
  bool has_jump_set_distance() const { return impl_->ProvidesJumpSetDistance(); }
  // Whether a flow φ_q may read guard parameter γ_i: false only when the struct says so
  // (FlowReadsGamma; a model file's flows that do not name it), so ∂(φα)/∂γ_i is zero, bit for bit.
  bool flow_reads_gamma(int i) const { return impl_->FlowReadsGamma(i); }
  double DistanceToJumpSet(const ConstVecRef& x) const { return impl_->DistanceToJumpSet(x, Resolve({})); }
  double DistanceToJumpSet(const ConstVecRef& x, const Context& ctx) const {
    return impl_->DistanceToJumpSet(x, Resolve(ctx));
  }

  // f(ξ) = φ(ξ)α and g(ξ) = ψ(ξ)β with the given parameter vectors.
  void Flow(const ConstVecRef& x, const ConstVecRef& alpha, VecRef dxdt) const {
    if (contextual_) return impl_->Flow(x, alpha, Resolve({}), dxdt);
    impl_->Flow(x, alpha, dxdt);
  }
  void Flow(const ConstVecRef& x, const ConstVecRef& alpha, VecRef dxdt, const Context& ctx) const {
    impl_->Flow(x, alpha, Resolve(ctx), dxdt);
  }
  void Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus) const {
    if (contextual_) return Jump(x, beta, xplus, Context{});
    impl_->Jump(x, beta, xplus);
  }
  // With Context::map naming an identity map (a mode switch): ξ+ = ξ.
  void Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus, const Context& ctx) const;
  // ∂(φ(ξ)α)/∂ξ, n × n: analytic when an x-only struct provides it, else central differences.
  void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, MatRef jac) const {
    if (contextual_) return impl_->FlowJacobian(x, alpha, Resolve({}), jac);
    impl_->FlowJacobian(x, alpha, jac);
  }
  void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, MatRef jac, const Context& ctx) const {
    impl_->FlowJacobian(x, alpha, Resolve(ctx), jac);
  }
  // ∂h/∂γ at (x, ctx), |guards| × |γ|, by central differences around ctx.gamma (or the model's γ).
  void GuardGammaJacobian(const ConstVecRef& x, const Context& ctx, MatRef dh_dgamma) const {
    GuardParameterJacobian(x, ctx, ParameterBlock::kGamma, dh_dgamma);
  }
  // ∂h/∂α (|guards| × |α|), ∂h/∂β (|guards| × |β|) or ∂h/∂γ at (x, ctx), by central differences around
  // the context's vector (or the model's own), step 1e-6·max(1, |value|); zero columns for entries no
  // guard reads.
  enum class ParameterBlock { kAlpha, kBeta, kGamma };
  void GuardParameterJacobian(const ConstVecRef& x, const Context& ctx, ParameterBlock block, MatRef dh) const;

  // Largest number of states and parameters (and inputs) the fixed-capacity scratch buffers allow.
  static constexpr int kMaxStates = 16;
  static constexpr int kMaxParameters = 32;
  // α alone may be longer: a model file's candidate terms, per mode of an automaton, are α entries.
  static constexpr int kMaxAlpha = 64;

 private:
  using ScratchMat =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxStates, kMaxAlpha>;

  struct Concept {
    virtual ~Concept() = default;
    virtual ModelSpec Spec() const = 0;
    // The x-only forms (the models without inputs and γ) ...
    virtual void Phi(const ConstVecRef& x, MatRef phi) const = 0;
    virtual void PhiColumns(const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                            double* phi) const = 0;
    virtual void PhiRowColumns(int row, const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                               double* phi) const = 0;
    virtual void Psi(const ConstVecRef& x, MatRef psi) const = 0;
    virtual void Guards(const ConstVecRef& x, VecRef h) const = 0;
    virtual bool InFlowSet(const ConstVecRef& x) const = 0;
    virtual bool InJumpSet(const ConstVecRef& x) const = 0;
    virtual void ProjectOntoGuard(int i, VecRef x) const = 0;
    virtual bool ProvidesJumpSetDistance() const = 0;
    virtual bool FlowReadsGamma(int i) const = 0;
    virtual double DistanceToJumpSet(const ConstVecRef& x) const = 0;
    virtual void Flow(const ConstVecRef& x, const ConstVecRef& alpha, VecRef dxdt) const = 0;
    virtual void Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus) const = 0;
    virtual void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, MatRef jac) const = 0;
    // ... and the context forms (ctx resolved: gamma set, u set when the model has inputs).
    virtual void Phi(const ConstVecRef& x, const Context& ctx, MatRef phi) const = 0;
    virtual void PhiColumns(const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                            const Context& ctx, double* phi) const = 0;
    virtual void PhiRowColumns(int row, const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                               const Context& ctx, double* phi) const = 0;
    virtual void Psi(const ConstVecRef& x, const Context& ctx, MatRef psi) const = 0;
    virtual void Guards(const ConstVecRef& x, const Context& ctx, VecRef h) const = 0;
    virtual bool InFlowSet(const ConstVecRef& x, const Context& ctx) const = 0;
    virtual bool InJumpSet(const ConstVecRef& x, const Context& ctx) const = 0;
    virtual void ProjectOntoGuard(int i, const Context& ctx, VecRef x) const = 0;
    virtual double DistanceToJumpSet(const ConstVecRef& x, const Context& ctx) const = 0;
    virtual void Flow(const ConstVecRef& x, const ConstVecRef& alpha, const Context& ctx, VecRef dxdt) const = 0;
    virtual void Jump(const ConstVecRef& x, const ConstVecRef& beta, const Context& ctx, VecRef xplus) const = 0;
    virtual void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, const Context& ctx,
                              MatRef jac) const = 0;
  };

  template <class M>
  struct Impl final : Concept {
    // A struct with the context forms is called with them; an x-only struct ignores the context.
    static constexpr bool kContext = ContextModel<M>;
    static inline const Context kNoContext{};
    explicit Impl(M m) : m_(std::move(m)) {}
    ModelSpec Spec() const override { return m_.Spec(); }

    void Phi(const ConstVecRef& x, MatRef phi) const override { Phi(x, kNoContext, phi); }
    void Phi(const ConstVecRef& x, const Context& ctx, MatRef phi) const override {
      if constexpr (kContext) {
        m_.Phi(x, ctx, phi);
      } else {
        m_.Phi(x, phi);
      }
    }
    void PhiColumns(const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                    double* phi) const override {
      PhiColumns(x, count, n, m, kNoContext, phi);
    }
    void PhiColumns(const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m, const Context& ctx,
                    double* phi) const override {
      if constexpr (kContext && HasContextPhiColumns<M>) {
        m_.PhiColumns(x, count, ctx, phi);
        return;
      } else if constexpr (!kContext && HasPhiColumns<M>) {
        m_.PhiColumns(x, count, phi);
        return;
      }
      for (Eigen::Index k = 0; k < count; ++k) {
        Eigen::Map<Mat> out(phi + k * n * m, n, m);
        Phi(Eigen::Map<const Vec>(x + k * n, n), ctx, out);
      }
    }
    void PhiRowColumns(int row, const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                       double* phi) const override {
      PhiRowColumns(row, x, count, n, m, kNoContext, phi);
    }
    void PhiRowColumns(int row, const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                       const Context& ctx, double* phi) const override {
      if constexpr (kContext && HasContextPhiRowColumns<M>) {
        m_.PhiRowColumns(row, x, count, ctx, phi);
      } else if constexpr (!kContext && HasPhiRowColumns<M>) {
        m_.PhiRowColumns(row, x, count, phi);
      } else {
        PhiColumns(x, count, n, m, ctx, phi);
      }
    }
    void Psi(const ConstVecRef& x, MatRef psi) const override { Psi(x, kNoContext, psi); }
    void Psi(const ConstVecRef& x, const Context& ctx, MatRef psi) const override {
      if constexpr (kContext) {
        m_.Psi(x, ctx, psi);
      } else {
        m_.Psi(x, psi);
      }
    }
    void Guards(const ConstVecRef& x, VecRef h) const override { Guards(x, kNoContext, h); }
    void Guards(const ConstVecRef& x, const Context& ctx, VecRef h) const override {
      if constexpr (kContext) {
        m_.Guards(x, ctx, h);
      } else {
        m_.Guards(x, h);
      }
    }
    bool InFlowSet(const ConstVecRef& x) const override { return InFlowSet(x, kNoContext); }
    bool InFlowSet(const ConstVecRef& x, const Context& ctx) const override {
      if constexpr (kContext) {
        return m_.InFlowSet(x, ctx);
      } else {
        return m_.InFlowSet(x);
      }
    }
    bool InJumpSet(const ConstVecRef& x) const override { return InJumpSet(x, kNoContext); }
    bool InJumpSet(const ConstVecRef& x, const Context& ctx) const override {
      if constexpr (kContext) {
        return m_.InJumpSet(x, ctx);
      } else {
        return m_.InJumpSet(x);
      }
    }
    void ProjectOntoGuard(int i, VecRef x) const override { ProjectOntoGuard(i, kNoContext, x); }
    void ProjectOntoGuard(int i, const Context& ctx, VecRef x) const override {
      if constexpr (kContext && HasContextGuardProjection<M>) {
        m_.ProjectOntoGuard(i, ctx, x);
      } else if constexpr (!kContext && HasGuardProjection<M>) {
        m_.ProjectOntoGuard(i, x);
      }
    }
    bool ProvidesJumpSetDistance() const override {
      if constexpr (requires {
                      { m_.ProvidesJumpSetDistance() } -> std::convertible_to<bool>;
                    }) {
        return m_.ProvidesJumpSetDistance();  // a struct whose distance is optional at run time
      } else {
        return kContext ? HasContextJumpSetDistance<M> : HasJumpSetDistance<M>;
      }
    }
    bool FlowReadsGamma(int i) const override {
      if constexpr (requires {
                      { m_.FlowReadsGamma(i) } -> std::convertible_to<bool>;
                    }) {
        return m_.FlowReadsGamma(i);
      } else {
        return kContext;  // an x-only model reads no γ
      }
    }
    double DistanceToJumpSet(const ConstVecRef& x) const override { return DistanceToJumpSet(x, kNoContext); }
    double DistanceToJumpSet(const ConstVecRef& x, const Context& ctx) const override {
      if constexpr (kContext && HasContextJumpSetDistance<M>) {
        return m_.DistanceToJumpSet(x, ctx);
      } else if constexpr (!kContext && HasJumpSetDistance<M>) {
        return m_.DistanceToJumpSet(x);
      } else {
        return std::numeric_limits<double>::quiet_NaN();
      }
    }
    void Flow(const ConstVecRef& x, const ConstVecRef& alpha, VecRef dxdt) const override {
      Flow(x, alpha, kNoContext, dxdt);
    }
    void Flow(const ConstVecRef& x, const ConstVecRef& alpha, const Context& ctx, VecRef dxdt) const override {
      ScratchMat phi(x.size(), alpha.size());
      Phi(x, ctx, phi);
      dxdt.noalias() = phi * alpha;
    }
    void Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus) const override {
      Jump(x, beta, kNoContext, xplus);
    }
    void Jump(const ConstVecRef& x, const ConstVecRef& beta, const Context& ctx, VecRef xplus) const override {
      ScratchMat psi(x.size(), beta.size());
      Psi(x, ctx, psi);
      xplus.noalias() = psi * beta;
    }
    void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, MatRef jac) const override {
      FlowJacobian(x, alpha, kNoContext, jac);
    }
    void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, const Context& ctx,
                      MatRef jac) const override {
      if constexpr (!kContext && HasFlowJacobian<M>) {
        m_.FlowJacobian(x, alpha, jac);
      } else {
        CentralDifferenceJacobian(*this, x, alpha, ctx, jac);
      }
    }
    M m_;
  };

  static void CentralDifferenceJacobian(const Concept& c, const ConstVecRef& x, const ConstVecRef& alpha,
                                        const Context& ctx, MatRef jac);
  void Init();
  void CheckSpec() const;
  void CheckAutomaton() const;
  int beta_size_spec() const { return static_cast<int>(spec_.beta.size()); }
  // ctx with γ, α and β filled in (the model's own where ctx has nullptr); throws std::logic_error when the
  // model has inputs and ctx.u is nullptr.
  Context Resolve(const Context& ctx) const {
    Context out = ctx;
    if (out.gamma == nullptr) out.gamma = gamma_.data();
    if (out.alpha == nullptr) out.alpha = alpha_.data();
    if (out.beta == nullptr) out.beta = beta_.data();
    if (out.u == nullptr && !spec_.inputs.empty()) ThrowMissingInputs();
    return out;
  }
  [[noreturn]] void ThrowMissingInputs() const;
  bool IsIdentityMap(int map) const {
    return map >= 0 && map < static_cast<int>(spec_.jumps.size()) && spec_.jumps[std::size_t(map)].identity;
  }

  std::shared_ptr<const Concept> impl_;
  ModelSpec spec_;
  Vec alpha_;
  Vec beta_;
  Vec gamma_;
  bool contextual_ = false;  // inputs, γ, modes or maps: the x-only forms go through Resolve
};

// ModelSpec::default_x0 as a vector (Model checks that it has one entry per state).
Vec DefaultState(const Model& model);
// The names of the unknown entries of `params` (ModelSpec::alpha, ::beta or ::guard_params), in order.
std::vector<std::string> UnknownNames(const std::vector<Parameter>& params);
// ModelSpec::measured, or 0 … n−1 when it is empty (every state measured).
std::vector<int> MeasuredIndices(const Model& model);

}  // namespace hysid

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

// One entry of α or β. `known` marks a constant of the model structure (the 1 in ξ1' = 1·ξ2); it is
// not identified and cannot be set from the command line.
struct Parameter {
  std::string name;
  double value = 0.0;
  bool known = false;
  std::string description;
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
};

// Which member functions a model struct must provide. ξ has size n = spec.state_names.size().
template <class M>
concept HybridModel = std::copy_constructible<M> &&
    requires(const M& m, ConstVecRef x, MatRef out_mat, VecRef out_vec) {
  { m.Spec() } -> std::convertible_to<ModelSpec>;
  m.Phi(x, out_mat);     // φ(ξ), n × |α|
  m.Psi(x, out_mat);     // ψ(ξ), n × |β|
  m.Guards(x, out_vec);  // h_i(ξ), one per spec.guards entry
  { m.InFlowSet(x) } -> std::convertible_to<bool>;
  { m.InJumpSet(x) } -> std::convertible_to<bool>;
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

template <class M>
concept HasGuardProjection = requires(const M& m, int i, VecRef x) {
  m.ProjectOntoGuard(i, x);
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
  int guard_count() const { return static_cast<int>(spec_.guards.size()); }

  // True parameter values (defaults from the spec unless set).
  const Vec& alpha() const { return alpha_; }
  const Vec& beta() const { return beta_; }
  // Sets an unknown parameter of α or β by name. Throws std::invalid_argument naming the parameter
  // when it does not exist, is a known constant, or `value` is not finite.
  void SetParameter(std::string_view name, double value);
  // Parses "name=value". Same errors as SetParameter, plus malformed text.
  void SetParameter(std::string_view assignment);

  void Phi(const ConstVecRef& x, MatRef phi) const { impl_->Phi(x, phi); }
  // φ at `count` states with one call (the struct's Phi inlined in the loop): state k is
  // x[k·n .. k·n + n) and its n × |α| φ goes, column-major, to phi + k·n·|α|. For paths that know
  // their samples ahead (RegressionBuilder::FlowRows).
  void PhiColumns(const double* x, Eigen::Index count, double* phi) const {
    impl_->PhiColumns(x, count, state_size(), alpha_size(), phi);
  }
  void Psi(const ConstVecRef& x, MatRef psi) const { impl_->Psi(x, psi); }
  void Guards(const ConstVecRef& x, VecRef h) const { impl_->Guards(x, h); }
  bool InFlowSet(const ConstVecRef& x) const { return impl_->InFlowSet(x); }
  bool InJumpSet(const ConstVecRef& x) const { return impl_->InJumpSet(x); }
  // Puts x exactly on guard i when the struct knows how; otherwise leaves x unchanged (the
  // simulator's direction filter then keeps the guard from firing again).
  void ProjectOntoGuard(int i, VecRef x) const { impl_->ProjectOntoGuard(i, x); }
  // Euclidean distance from x to D when the struct provides DistanceToJumpSet, else NaN.
  bool has_jump_set_distance() const { return impl_->ProvidesJumpSetDistance(); }
  double DistanceToJumpSet(const ConstVecRef& x) const { return impl_->DistanceToJumpSet(x); }

  // f(ξ) = φ(ξ)α and g(ξ) = ψ(ξ)β with the given parameter vectors.
  void Flow(const ConstVecRef& x, const ConstVecRef& alpha, VecRef dxdt) const {
    impl_->Flow(x, alpha, dxdt);
  }
  void Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus) const {
    impl_->Jump(x, beta, xplus);
  }
  // ∂(φ(ξ)α)/∂ξ, n × n: analytic when the struct provides it, else central differences.
  void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, MatRef jac) const {
    impl_->FlowJacobian(x, alpha, jac);
  }

  // Largest number of states and parameters the fixed-capacity scratch buffers allow.
  static constexpr int kMaxStates = 16;
  static constexpr int kMaxParameters = 32;

 private:
  using ScratchMat =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxStates, kMaxParameters>;

  struct Concept {
    virtual ~Concept() = default;
    virtual ModelSpec Spec() const = 0;
    virtual void Phi(const ConstVecRef& x, MatRef phi) const = 0;
    virtual void PhiColumns(const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                            double* phi) const = 0;
    virtual void Psi(const ConstVecRef& x, MatRef psi) const = 0;
    virtual void Guards(const ConstVecRef& x, VecRef h) const = 0;
    virtual bool InFlowSet(const ConstVecRef& x) const = 0;
    virtual bool InJumpSet(const ConstVecRef& x) const = 0;
    virtual void ProjectOntoGuard(int i, VecRef x) const = 0;
    virtual bool ProvidesJumpSetDistance() const = 0;
    virtual double DistanceToJumpSet(const ConstVecRef& x) const = 0;
    virtual void Flow(const ConstVecRef& x, const ConstVecRef& alpha, VecRef dxdt) const = 0;
    virtual void Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus) const = 0;
    virtual void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, MatRef jac) const = 0;
  };

  template <class M>
  struct Impl final : Concept {
    explicit Impl(M m) : m_(std::move(m)) {}
    ModelSpec Spec() const override { return m_.Spec(); }
    void Phi(const ConstVecRef& x, MatRef phi) const override { m_.Phi(x, phi); }
    void PhiColumns(const double* x, Eigen::Index count, Eigen::Index n, Eigen::Index m,
                    double* phi) const override {
      if constexpr (HasPhiColumns<M>) {
        m_.PhiColumns(x, count, phi);
        return;
      }
      for (Eigen::Index k = 0; k < count; ++k) {
        Eigen::Map<Mat> out(phi + k * n * m, n, m);
        m_.Phi(Eigen::Map<const Vec>(x + k * n, n), out);
      }
    }
    void Psi(const ConstVecRef& x, MatRef psi) const override { m_.Psi(x, psi); }
    void Guards(const ConstVecRef& x, VecRef h) const override { m_.Guards(x, h); }
    bool InFlowSet(const ConstVecRef& x) const override { return m_.InFlowSet(x); }
    bool InJumpSet(const ConstVecRef& x) const override { return m_.InJumpSet(x); }
    void ProjectOntoGuard(int i, VecRef x) const override {
      if constexpr (HasGuardProjection<M>) m_.ProjectOntoGuard(i, x);
    }
    bool ProvidesJumpSetDistance() const override {
      if constexpr (requires {
                      { m_.ProvidesJumpSetDistance() } -> std::convertible_to<bool>;
                    }) {
        return m_.ProvidesJumpSetDistance();  // a struct whose distance is optional at run time
      } else {
        return HasJumpSetDistance<M>;
      }
    }
    double DistanceToJumpSet(const ConstVecRef& x) const override {
      if constexpr (HasJumpSetDistance<M>) {
        return m_.DistanceToJumpSet(x);
      } else {
        return std::numeric_limits<double>::quiet_NaN();
      }
    }
    void Flow(const ConstVecRef& x, const ConstVecRef& alpha, VecRef dxdt) const override {
      ScratchMat phi(x.size(), alpha.size());
      m_.Phi(x, phi);
      dxdt.noalias() = phi * alpha;
    }
    void Jump(const ConstVecRef& x, const ConstVecRef& beta, VecRef xplus) const override {
      ScratchMat psi(x.size(), beta.size());
      m_.Psi(x, psi);
      xplus.noalias() = psi * beta;
    }
    void FlowJacobian(const ConstVecRef& x, const ConstVecRef& alpha, MatRef jac) const override {
      if constexpr (HasFlowJacobian<M>) {
        m_.FlowJacobian(x, alpha, jac);
      } else {
        CentralDifferenceJacobian(*this, x, alpha, jac);
      }
    }
    M m_;
  };

  static void CentralDifferenceJacobian(const Concept& c, const ConstVecRef& x, const ConstVecRef& alpha,
                                        MatRef jac);
  void Init();

  std::shared_ptr<const Concept> impl_;
  ModelSpec spec_;
  Vec alpha_;
  Vec beta_;
};

// ModelSpec::default_x0 as a vector (Model checks that it has one entry per state).
Vec DefaultState(const Model& model);
// The names of the unknown entries of `params` (ModelSpec::alpha or ::beta), in order.
std::vector<std::string> UnknownNames(const std::vector<Parameter>& params);

}  // namespace hysid

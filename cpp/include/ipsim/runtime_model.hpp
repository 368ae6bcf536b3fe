// ipsim::RuntimeModel: a model tag whose equations come from a model library loaded at run time
// (the C interface of cpp/include/ipgen_model.h), so that ipsim is compiled once for every model.
//
// Its sizes are Eigen::Dynamic with the capacity IPGEN_MAX_DOF (vectors and matrices live on the
// stack: no allocation per right-hand side); its functions call the loaded model's. One model is
// active per process: ModelLibrary loads it (dlopen) and makes it the active one.
#pragma once

#include <dlfcn.h>

#include <cmath>
#include <limits>
#include <string>
#include <string_view>

#include <Eigen/Core>

#include "ipgen_model.h"
#include "ipsim/errors.hpp"
#include "ipsim/model.hpp"

/// A model linked into the program (its adapter, NAME_model.c, compiled in: CMake's
/// ipgen_add_runtime_simulator); null when none is, and the model comes from a library instead.
extern "C" const ipgen_model* ipgen_model_get(void) __attribute__((weak));

namespace ipsim {

/// The tag of a model loaded at run time (see ModelLibrary).
struct RuntimeModel {
  static constexpr int kDof = Eigen::Dynamic;
  static constexpr int kLinks = Eigen::Dynamic;
  static constexpr int kMaxDof = IPGEN_MAX_DOF;
  static constexpr bool kSpecialised = false;  // a specialised model is told by check_folded

  /// The parameters in the interface's layout (ipgen_parameters), with the header's defaults:
  /// g = 9.81, com and J unset (NaN: the homogeneous rods), no axial inertia, no tip masses.
  template <typename Scalar = double>
  struct Params : ipgen_parameters {
    static_assert(std::is_same_v<Scalar, double>, "a model loaded at run time computes in double");
    Params() : ipgen_parameters{} {
      g = 9.81;
      for (int i = 0; i < IPGEN_MAX_DOF; ++i) com[i] = J[i] = std::numeric_limits<double>::quiet_NaN();
    }
  };
  template <typename Scalar>
  using Vector = Eigen::Matrix<Scalar, Eigen::Dynamic, 1, Eigen::ColMajor, kMaxDof, 1>;
  template <typename Scalar>
  using Matrix = Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, kMaxDof, kMaxDof>;
  using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, kMaxDof, kMaxDof>;
  using StateMatrix =
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor, 2 * kMaxDof, 2 * kMaxDof>;

  template <typename Scalar>
  struct Derivatives {
    Vector<Scalar> qdd;       ///< accelerations
    Matrix<Scalar> dqdd_dq;   ///< ∂θ̈/∂θ (column i: with respect to θ(i))
    Matrix<Scalar> dqdd_dqd;  ///< ∂θ̈/∂θ̇
    Vector<Scalar> dqdd_du;   ///< ∂θ̈/∂u
  };
  template <typename Scalar>
  struct Linearization {
    Eigen::Matrix<Scalar, Eigen::Dynamic, Eigen::Dynamic, Eigen::ColMajor, 2 * kMaxDof, 2 * kMaxDof> A;
    Eigen::Matrix<Scalar, Eigen::Dynamic, 1, Eigen::ColMajor, 2 * kMaxDof, 1> B;
  };

  /// The active model (ModelLibrary sets it); throws when none is loaded.
  static const ipgen_model& active() {
    if (loaded() == nullptr) throw Error("no model library is loaded");
    return *loaded();
  }
  /// Makes `model` the active one (nullptr: none).
  static void activate(const ipgen_model* model) { loaded() = model; }

  static int dof() { return active().dof; }
  static int links() { return active().links; }
  /// m: the inputs u[0..m) (a cart or an arm: 1; a fixed chain: one per driven joint).
  static int inputs() { return active().inputs; }
  /// B of M θ̈ + bias = B u (dof × inputs, row-major), or null.
  static const double* input_matrix() { return active().input_matrix; }
  /// A fixed chain's driven joints (inputs entries, 1 = the shoulder); null for a cart or an arm.
  static const int* joints() { return active().joints; }
  /// Whether the model is a chain on a fixed pivot (dof = links, inputs at joints).
  static bool fixed_pivot() { return std::string_view(type()) == "fixed"; }
  static const char* name() { return active().name; }
  static const char* type() { return active().type; }
  static const char* inertia() { return active().inertia; }
  static bool provides(Feature feature) {
    const ipgen_model& m = active();
    switch (feature) {
      case Feature::mass_matrix: return m.mass_matrix != nullptr;
      case Feature::mass_and_bias: return m.mass_matrix != nullptr && m.bias != nullptr;
      case Feature::derivatives: return m.forward_dynamics_derivatives != nullptr;
      case Feature::energy: return m.kinetic_energy && m.potential_energy && m.dissipation;
    }
    return false;
  }

  template <typename Scalar>
  static const char* check_folded(const Params<Scalar>& p) {
    return active().check_folded ? active().check_folded(&p) : nullptr;
  }
  template <typename Scalar>
  static Params<Scalar> with_rod_links(const Params<Scalar>& p) {
    Params<Scalar> filled = p;
    if (active().rod_links) active().rod_links(&filled);
    return filled;
  }
  template <typename Scalar>
  static Matrix<Scalar> mass_matrix(const Vector<Scalar>& q, const Params<Scalar>& p) {
    Matrix<Scalar> M(q.size(), q.size());  // symmetric: the row-major result reads the same
    function(active().mass_matrix, "mass_matrix")(q.data(), &p, M.data());
    return M;
  }
  template <typename Scalar>
  static Vector<Scalar> bias(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
    Vector<Scalar> b(q.size());
    function(active().bias, "bias")(q.data(), qd.data(), &p, b.data());
    return b;
  }
  /// P(θ) = ∂V/∂θ and N(θ, θ̇) (bias = N θ̇ + P): optional in a model library (ipsim calls
  /// neither; the tests check the model's functions against each other with them).
  template <typename Scalar>
  static Vector<Scalar> gravity(const Vector<Scalar>& q, const Params<Scalar>& p) {
    Vector<Scalar> P(q.size());
    function(active().gravity, "gravity")(q.data(), &p, P.data());
    return P;
  }
  template <typename Scalar>
  static Matrix<Scalar> n_matrix(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
    RowMajorMatrix N(q.size(), q.size());  // the interface's matrices are row-major
    function(active().n_matrix, "n_matrix")(q.data(), qd.data(), &p, N.data());
    return Matrix<Scalar>(N);
  }
  /// θ̈; NaN when M(θ) is not positive definite (as the headers' LDLT gives no finite answer).
  template <typename Scalar>
  static Vector<Scalar> forward_dynamics(const Vector<Scalar>& q, const Vector<Scalar>& qd, Scalar u,
                                         const Params<Scalar>& p) {
    Vector<Scalar> qdd(q.size());
    const Inputs all(u);
    if (function(active().forward_dynamics, "forward_dynamics")(q.data(), qd.data(), all.u, &p, qdd.data()) != 0) {
      qdd.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
    return qdd;
  }
  /// forward_dynamics on the state's own arrays, for the right-hand side (rhs.hpp): no vector is
  /// copied on the way (per call, those copies cost a third of a small model's time). θ̈ is NaN
  /// when M(θ) is not positive definite.
  static void forward_dynamics_into(const double q[], const double qd[], double u, const Params<double>& p,
                                    double qdd[], int n) {
    const Inputs all(u);
    forward_dynamics_inputs_into(q, qd, all.u, p, qdd, n);
  }
  /// forward_dynamics_into with every input: u[0..inputs()).
  static void forward_dynamics_inputs_into(const double q[], const double qd[], const double u[],
                                           const Params<double>& p, double qdd[], int n) {
    if (function(active().forward_dynamics, "forward_dynamics")(q, qd, u, &p, qdd) != 0) {
      for (int i = 0; i < n; ++i) qdd[i] = std::numeric_limits<double>::quiet_NaN();
    }
  }
  /// Whether the model library has rk4_step (ipgen_model.h).
  static bool has_rk4_step() { return active().rk4_step != nullptr; }
  /// One RK4 step h [s] of x = [q; qd] in place, the inputs u[0..inputs()) held (the library's
  /// rk4_step, which has_rk4_step() says exists): 0, or non-zero with x unchanged.
  static int rk4_step(double x[], const double u[], double h, const Params<double>& p) {
    return active().rk4_step(x, u, h, &p);
  }
  template <typename Scalar>
  static Derivatives<Scalar> forward_dynamics_derivatives(const Vector<Scalar>& q, const Vector<Scalar>& qd,
                                                          Scalar u, const Params<Scalar>& p) {
    const Inputs all(u);
    return forward_dynamics_derivatives_inputs<Scalar>(q, qd, all.u, p);
  }
  /// forward_dynamics_derivatives with every input u[0..inputs()); dqdd_du is ∂θ̈/∂u of the first.
  template <typename Scalar>
  static Derivatives<Scalar> forward_dynamics_derivatives_inputs(const Vector<Scalar>& q, const Vector<Scalar>& qd,
                                                                 const double u[], const Params<Scalar>& p) {
    const Eigen::Index n = q.size();
    const int m = inputs();
    Derivatives<Scalar> d;
    d.qdd.resize(n);
    d.dqdd_du.resize(n);
    RowMajorMatrix dq(n, n), dqd(n, n);
    double du[IPGEN_MAX_DOF * IPGEN_MAX_INPUTS];  // dof × inputs, row-major
    if (function(active().forward_dynamics_derivatives, "forward_dynamics_derivatives")(
            q.data(), qd.data(), u, &p, d.qdd.data(), dq.data(), dqd.data(), du) == 0) {
      for (Eigen::Index i = 0; i < n; ++i) d.dqdd_du(i) = du[i * m];
    } else {
      const double nan = std::numeric_limits<double>::quiet_NaN();
      d.qdd.setConstant(nan);
      d.dqdd_du.setConstant(nan);
      dq.setConstant(nan);
      dqd.setConstant(nan);
    }
    d.dqdd_dq = dq;
    d.dqdd_dqd = dqd;
    return d;
  }
  template <typename Scalar>
  static Linearization<Scalar> linearize(const Vector<Scalar>& q, const Vector<Scalar>& qd, Scalar u,
                                         const Params<Scalar>& p) {
    const Eigen::Index size = 2 * q.size();
    StateMatrix A(size, size);
    Linearization<Scalar> lin;
    lin.B.resize(size);
    const Inputs all(u);
    const int m = inputs();
    double B[2 * IPGEN_MAX_DOF * IPGEN_MAX_INPUTS];  // 2 dof × inputs, row-major: the first column is lin.B
    if (function(active().linearize, "linearize")(q.data(), qd.data(), all.u, &p, A.data(), B) == 0) {
      for (Eigen::Index i = 0; i < size; ++i) lin.B(i) = B[i * m];
    } else {
      A.setConstant(std::numeric_limits<double>::quiet_NaN());
      lin.B.setConstant(std::numeric_limits<double>::quiet_NaN());
    }
    lin.A = A;
    return lin;
  }
  template <typename Scalar>
  static Scalar kinetic_energy(const Vector<Scalar>& q, const Vector<Scalar>& qd, const Params<Scalar>& p) {
    return function(active().kinetic_energy, "kinetic_energy")(q.data(), qd.data(), &p);
  }
  template <typename Scalar>
  static Scalar potential_energy(const Vector<Scalar>& q, const Params<Scalar>& p) {
    return function(active().potential_energy, "potential_energy")(q.data(), &p);
  }
  template <typename Scalar>
  static Scalar dissipation(const Vector<Scalar>& qd, const Params<Scalar>& p) {
    return function(active().dissipation, "dissipation")(qd.data(), &p);
  }

 private:
  /// u[0..inputs()) of a call with one input u: the others 0 (a fixed chain's other motors idle).
  struct Inputs {
    double u[IPGEN_MAX_INPUTS];
    explicit Inputs(double first) {
      u[0] = first;
      for (int k = 1; k < active().inputs; ++k) u[k] = 0.0;
    }
  };
  static const ipgen_model*& loaded() {
    static const ipgen_model* model = nullptr;
    return model;
  }
  /// `f`, or an Error naming the function the model lacks (ipsim checks before it calls).
  template <class F>
  static F function(F f, const char* what) {
    if (f == nullptr) throw Error(std::string("model ") + active().name + " has no " + what);
    return f;
  }
};

/// A model library (a shared object exporting ipgen_model_get), loaded and made the active
/// RuntimeModel for the object's lifetime; unloaded after. Or, constructed with no path, the
/// model linked into the program.
class ModelLibrary {
 public:
  /// The model linked into the program; throws Error when none is.
  ModelLibrary() {
    const ipgen_model* model = ::ipgen_model_get ? ::ipgen_model_get() : nullptr;
    if (model == nullptr) throw Error("no model is linked into this simulator: pass --model LIB");
    const std::string problem = problem_with(*model);
    if (!problem.empty()) throw Error("cannot use the linked model: " + problem);
    RuntimeModel::activate(model);
    model_ = model;
  }

  /// Loads `path` (a file name without a folder is the current folder's, as on a command line: not
  /// searched for on the system's library path, where another library of that name could be);
  /// throws Error naming the problem (no such file, not a model library, another ABI, sizes out of
  /// range).
  explicit ModelLibrary(const std::string& path) {
    const std::string file = path.find('/') == std::string::npos ? "./" + path : path;
    handle_ = dlopen(file.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (handle_ == nullptr) {
      const char* why = dlerror();
      throw Error("cannot load the model library " + path + ": " + (why ? why : "dlopen failed"));
    }
    auto get = reinterpret_cast<ipgen_model_get_fn>(dlsym(handle_, IPGEN_MODEL_SYMBOL));
    const ipgen_model* model = get ? get() : nullptr;
    const std::string problem =
        model == nullptr ? "it exports no " IPGEN_MODEL_SYMBOL " (not an ipgen model library)" : problem_with(*model);
    if (!problem.empty()) {
      dlclose(handle_);
      throw Error("cannot use the model library " + path + ": " + problem);
    }
    RuntimeModel::activate(model);
    model_ = model;
  }
  ~ModelLibrary() {
    RuntimeModel::activate(nullptr);
    if (handle_ != nullptr) dlclose(handle_);
  }
  ModelLibrary(const ModelLibrary&) = delete;
  ModelLibrary& operator=(const ModelLibrary&) = delete;

  const ipgen_model& model() const { return *model_; }

 private:
  /// What makes `model` unusable here, or "".
  static std::string problem_with(const ipgen_model& model) {
    if (model.abi != IPGEN_MODEL_ABI) {
      return "it was built for model ABI " + std::to_string(model.abi) + ", this simulator reads " +
             std::to_string(IPGEN_MODEL_ABI) + " (rebuild it with this ipgen)";
    }
    const bool fixed = std::string(model.type ? model.type : "") == "fixed";
    if (model.links < 1 || model.dof != model.links + (fixed ? 0 : 1) || model.dof > IPGEN_MAX_DOF) {
      return "its sizes are out of range (links " + std::to_string(model.links) + ", dof " +
             std::to_string(model.dof) + "; at most " + std::to_string(IPGEN_MAX_DOF) + " dof)";
    }
    if (model.inputs < 1 || model.inputs > IPGEN_MAX_INPUTS || (!fixed && model.inputs != 1) ||
        (fixed && (model.joints == nullptr || model.inputs > model.links)) || model.input_matrix == nullptr) {
      return "its inputs are out of range (" + std::to_string(model.inputs) +
             " inputs; a cart or an arm has one, a fixed chain one per driven joint with its joints and B)";
    }
    if (model.forward_dynamics == nullptr) return "it has no forward_dynamics";
    return "";
  }

  void* handle_ = nullptr;
  const ipgen_model* model_ = nullptr;
};

}  // namespace ipsim

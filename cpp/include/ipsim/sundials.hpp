// RAII ownership of the SUNDIALS objects a CVODE or ARKODE run needs.
//
// Every wrapper is non-copyable and movable; a moved-from wrapper owns nothing. Members of a
// struct are destroyed in reverse declaration order, so declaring them as
//   Context, NVector(s), DenseMatrix, DenseLinearSolver / NonlinearSolver, CvodeMemory / ErkMemory
// frees the integrator first (it refers to the solvers and the matrix) and the context last, as
// SUNDIALS requires.
#pragma once

#include <cstdlib>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>

#include <arkode/arkode_erkstep.h>
#include <cvode/cvode.h>
#include <nvector/nvector_serial.h>
#include <sundials/sundials_context.h>
#include <sunlinsol/sunlinsol_dense.h>
#include <sunmatrix/sunmatrix_dense.h>
#include <sunnonlinsol/sunnonlinsol_fixedpoint.h>

namespace ipsim::sundials {

/// Owns a SUNContext (SUNContext_Create / SUNContext_Free). Must outlive every object created
/// with it.
class Context {
 public:
  /// Creates a context without an MPI communicator. Throws std::runtime_error on failure.
  Context() {
    if (SUNContext_Create(nullptr, &context_) != 0 || context_ == nullptr) {
      throw std::runtime_error("SUNContext_Create failed");
    }
  }
  ~Context() {
    if (context_ != nullptr) SUNContext_Free(&context_);
  }
  Context(const Context&) = delete;
  Context& operator=(const Context&) = delete;
  Context(Context&& other) noexcept : context_(other.context_) { other.context_ = nullptr; }
  Context& operator=(Context&& other) noexcept {
    if (this != &other) {
      if (context_ != nullptr) SUNContext_Free(&context_);
      context_ = other.context_;
      other.context_ = nullptr;
    }
    return *this;
  }

  /// The raw handle, for passing to SUNDIALS constructors.
  SUNContext get() const noexcept { return context_; }

 private:
  SUNContext context_ = nullptr;
};

namespace detail {
struct NVectorDeleter {
  void operator()(N_Vector v) const noexcept { N_VDestroy(v); }
};
struct MatrixDeleter {
  void operator()(SUNMatrix a) const noexcept { SUNMatDestroy(a); }
};
struct LinearSolverDeleter {
  void operator()(SUNLinearSolver s) const noexcept { SUNLinSolFree(s); }
};
struct NonlinearSolverDeleter {
  void operator()(SUNNonlinearSolver s) const noexcept { SUNNonlinSolFree(s); }
};
struct CvodeDeleter {
  void operator()(void* mem) const noexcept { CVodeFree(&mem); }
};
struct ErkDeleter {
  void operator()(void* mem) const noexcept { ERKStepFree(&mem); }
};

/// A SUNDIALS flag name from a *GetReturnFlagName function (which hands back a malloc'ed string
/// the caller must free), or "<what> flag <n>" when it has none.
inline std::string owned_name(char* name, const char* what, long flag) {
  std::unique_ptr<char, decltype(&std::free)> owned(name, &std::free);
  return owned ? std::string(owned.get()) : std::string(what) + " flag " + std::to_string(flag);
}

/// Throws if a SUNDIALS constructor returned null.
template <typename Pointer>
Pointer require(Pointer p, const char* what) {
  if (p == nullptr) throw std::runtime_error(std::string(what) + " failed (out of memory?)");
  return p;
}
}  // namespace detail

/// Owns a serial N_Vector of doubles.
class NVector {
 public:
  /// Allocates a vector of `length` entries (uninitialised).
  NVector(sunindextype length, const Context& context)
      : vector_(detail::require(N_VNew_Serial(length, context.get()), "N_VNew_Serial")) {}

  /// The raw handle.
  N_Vector get() const noexcept { return vector_.get(); }
  /// Pointer to the first of length() contiguous entries.
  realtype* data() const noexcept { return N_VGetArrayPointer(vector_.get()); }
  /// Number of entries.
  sunindextype length() const noexcept { return N_VGetLength(vector_.get()); }

 private:
  std::unique_ptr<std::remove_pointer_t<N_Vector>, detail::NVectorDeleter> vector_;
};

/// Owns a dense (column-major) SUNMatrix.
class DenseMatrix {
 public:
  /// Allocates a rows × cols dense matrix.
  DenseMatrix(sunindextype rows, sunindextype cols, const Context& context)
      : matrix_(detail::require(SUNDenseMatrix(rows, cols, context.get()), "SUNDenseMatrix")) {}

  /// The raw handle.
  SUNMatrix get() const noexcept { return matrix_.get(); }

 private:
  std::unique_ptr<std::remove_pointer_t<SUNMatrix>, detail::MatrixDeleter> matrix_;
};

/// Owns a dense direct SUNLinearSolver (LU with partial pivoting) bound to a template vector
/// and matrix of matching size.
class DenseLinearSolver {
 public:
  DenseLinearSolver(const NVector& y, const DenseMatrix& a, const Context& context)
      : solver_(detail::require(SUNLinSol_Dense(y.get(), a.get(), context.get()), "SUNLinSol_Dense")) {}

  /// The raw handle.
  SUNLinearSolver get() const noexcept { return solver_.get(); }

 private:
  std::unique_ptr<std::remove_pointer_t<SUNLinearSolver>, detail::LinearSolverDeleter> solver_;
};

/// Owns a fixed-point (functional iteration) SUNNonlinearSolver without Anderson acceleration,
/// for CVODE's Adams method without a Jacobian.
class FixedPointSolver {
 public:
  FixedPointSolver(const NVector& y, const Context& context)
      : solver_(detail::require(SUNNonlinSol_FixedPoint(y.get(), 0, context.get()), "SUNNonlinSol_FixedPoint")) {}

  /// The raw handle.
  SUNNonlinearSolver get() const noexcept { return solver_.get(); }

 private:
  std::unique_ptr<std::remove_pointer_t<SUNNonlinearSolver>, detail::NonlinearSolverDeleter> solver_;
};

/// Owns CVODE's integrator memory (CVodeCreate / CVodeFree).
class CvodeMemory {
 public:
  /// `method` is CV_BDF or CV_ADAMS.
  CvodeMemory(int method, const Context& context)
      : memory_(detail::require(CVodeCreate(method, context.get()), "CVodeCreate")) {}

  /// The raw handle passed to every CVode* function.
  void* get() const noexcept { return memory_.get(); }

 private:
  std::unique_ptr<void, detail::CvodeDeleter> memory_;
};

/// Owns an ARKODE explicit Runge–Kutta integrator (ERKStepCreate / ERKStepFree).
class ErkMemory {
 public:
  /// Creates ERKStep for ẏ = f(t, y) from (t0, y0); y0 is copied.
  ErkMemory(ARKRhsFn f, double t0, const NVector& y0, const Context& context)
      : memory_(detail::require(ERKStepCreate(f, t0, y0.get(), context.get()), "ERKStepCreate")) {}

  /// The raw handle passed to every ERKStep* function.
  void* get() const noexcept { return memory_.get(); }

 private:
  std::unique_ptr<void, detail::ErkDeleter> memory_;
};

/// The name of a CVODE return flag, e.g. "CV_TOO_MUCH_WORK".
inline std::string return_flag_name(int flag) {
  return detail::owned_name(CVodeGetReturnFlagName(flag), "CVODE", flag);
}

/// The name of an ARKODE return flag, e.g. "ARK_TOO_MUCH_WORK".
inline std::string erk_return_flag_name(int flag) {
  return detail::owned_name(ERKStepGetReturnFlagName(flag), "ARKODE", flag);
}

}  // namespace ipsim::sundials

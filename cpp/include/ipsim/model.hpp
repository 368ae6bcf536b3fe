// What ipsim needs from a model tag type, and shorthands for its types.
//
// A model tag (e.g. ipgen::cdip::Model, written by the ipgen generator) provides
//   kLinks, kDof = kLinks + 1, kName, kType ("classical" | "rotary"), optionally kInertia
//   ("pivot" | "full" for rotary models, "" otherwise),
//   Params<Scalar>, Vector<Scalar>, and static function templates
//   mass_matrix, bias, gravity, n_matrix, forward_dynamics, kinetic_energy, potential_energy,
//   dissipation
// for the manipulator equation  M(θ) θ̈ + bias(θ, θ̇) = (u, 0, …, 0)ᵀ.
//
// Or a model loaded at run time (ipsim::RuntimeModel, ipsim/runtime_model.hpp): kDof and kLinks
// are then Eigen::Dynamic, kMaxDof bounds them, and dof_of, links_of, name_of, type_of and
// provides() ask the loaded model. Generic code uses those and the size aliases below, so that
// one instantiation on RuntimeModel runs every model (the simulator compiled once).
#pragma once

#include <string_view>
#include <type_traits>
#include <utility>

#include <Eigen/Core>

namespace ipsim {

/// Physical parameters of `Model` in double precision (masses [kg], lengths [m], damping, g).
template <class Model>
using ParamsOf = typename Model::template Params<double>;

/// Generalised coordinates or velocities of `Model` (dim Model::kDof).
template <class Model>
using VectorOf = typename Model::template Vector<double>;

/// True for a model whose sizes are known only at run time (RuntimeModel).
template <class Model>
inline constexpr bool is_runtime = Model::kDof == Eigen::Dynamic;

namespace detail {
template <class Model, class = void>
struct MaxDof {
  static constexpr int value = Model::kDof;
};
template <class Model>
struct MaxDof<Model, std::void_t<decltype(Model::kMaxDof)>> {
  static constexpr int value = Model::kMaxDof;
};
constexpr int times(int k, int n) { return n == Eigen::Dynamic ? Eigen::Dynamic : k * n; }
constexpr int less_one(int n) { return n == Eigen::Dynamic ? Eigen::Dynamic : n - 1; }
}  // namespace detail

/// The sizes of `Model` for Eigen types: fixed for a generated header, Eigen::Dynamic with a
/// fixed capacity (no allocation) for a model loaded at run time.
template <class Model>
struct SizesOf {
  static constexpr int dof = Model::kDof;  ///< base + links, or Eigen::Dynamic
  static constexpr int max_dof = detail::MaxDof<Model>::value;
  static constexpr int links = detail::less_one(dof);
  static constexpr int max_links = max_dof - 1;
  static constexpr int state = detail::times(2, dof);  ///< x = [θ; θ̇]
  static constexpr int max_state = 2 * max_dof;
};

/// kDof × kDof (mass matrix, a Jacobian block).
template <class Model>
using DofMatrixOf = Eigen::Matrix<double, SizesOf<Model>::dof, SizesOf<Model>::dof, Eigen::ColMajor,
                                  SizesOf<Model>::max_dof, SizesOf<Model>::max_dof>;
/// kDof × 2·kDof (∂θ̈/∂x).
template <class Model>
using DofStateMatrixOf = Eigen::Matrix<double, SizesOf<Model>::dof, SizesOf<Model>::state, Eigen::ColMajor,
                                       SizesOf<Model>::max_dof, SizesOf<Model>::max_state>;
/// The links' block of the mass matrix, kLinks × kLinks.
template <class Model>
using LinksMatrixOf = Eigen::Matrix<double, SizesOf<Model>::links, SizesOf<Model>::links, Eigen::ColMajor,
                                    SizesOf<Model>::max_links, SizesOf<Model>::max_links>;
/// A vector over the links (kLinks).
template <class Model>
using LinksVectorOf =
    Eigen::Matrix<double, SizesOf<Model>::links, 1, Eigen::ColMajor, SizesOf<Model>::max_links, 1>;
/// A vector over the state x = [θ; θ̇] (2·kDof).
template <class Model>
using StateVectorOf =
    Eigen::Matrix<double, SizesOf<Model>::state, 1, Eigen::ColMajor, SizesOf<Model>::max_state, 1>;
/// A row over the state (2·kDof): a gain, a row of A.
template <class Model>
using StateRowOf =
    Eigen::Matrix<double, 1, SizesOf<Model>::state, Eigen::RowMajor, 1, SizesOf<Model>::max_state>;

/// Degrees of freedom (base + links) of `Model`.
template <class Model>
int dof_of() {
  if constexpr (is_runtime<Model>) {
    return Model::dof();
  } else {
    return Model::kDof;
  }
}

/// Number of links of `Model`.
template <class Model>
int links_of() {
  if constexpr (is_runtime<Model>) {
    return Model::links();  // a fixed chain: dof = links
  } else {
    return dof_of<Model>() - 1;
  }
}

/// The model's name ("cdip") and type ("classical" | "rotary").
template <class Model>
const char* name_of() {
  if constexpr (is_runtime<Model>) {
    return Model::name();
  } else {
    return Model::kName;
  }
}
template <class Model>
const char* type_of() {
  if constexpr (is_runtime<Model>) {
    return Model::type();
  } else {
    return Model::kType;
  }
}

/// A zero vector of the model's coordinates (kDof).
template <class Model>
VectorOf<Model> zero_vector() {
  return VectorOf<Model>::Zero(dof_of<Model>());
}

/// True for a pendulum on a cart (θ0 in metres, l[0] unused), false for a rotary (Furuta) base.
template <class Model>
bool is_classical() {
  return std::string_view(type_of<Model>()) == "classical";
}

namespace detail {
template <class Model, class = void>
struct InertiaOf {
  static constexpr std::string_view value{};
};
template <class Model>
struct InertiaOf<Model, std::void_t<decltype(Model::kInertia)>> {
  static constexpr std::string_view value{Model::kInertia};
};
}  // namespace detail

/// The rotary inertia variant the model was generated with ("pivot" or "full"); empty for
/// classical models and for model tags without kInertia.
template <class Model>
std::string_view inertia_of() {
  if constexpr (is_runtime<Model>) {
    return Model::inertia();
  } else {
    return detail::InertiaOf<Model>::value;
  }
}

namespace detail {
template <class Model, class = void>
struct HasEnergy : std::false_type {};
template <class Model>
struct HasEnergy<Model, std::void_t<decltype(Model::template kinetic_energy<double>(
                                        std::declval<const VectorOf<Model>&>(), std::declval<const VectorOf<Model>&>(),
                                        std::declval<const ParamsOf<Model>&>())),
                                    decltype(Model::template potential_energy<double>(
                                        std::declval<const VectorOf<Model>&>(), std::declval<const ParamsOf<Model>&>())),
                                    decltype(Model::template dissipation<double>(
                                        std::declval<const VectorOf<Model>&>(), std::declval<const ParamsOf<Model>&>()))>>
    : std::true_type {};

template <class Model, class = void>
struct HasCheckFolded : std::false_type {};
template <class Model>
struct HasCheckFolded<Model, std::void_t<decltype(Model::template check_folded<double>(
                                 std::declval<const ParamsOf<Model>&>()))>> : std::true_type {};
}  // namespace detail

namespace detail {
template <class Model, class = void>
struct HasLinksAsBuilt : std::false_type {};
template <class Model>
struct HasLinksAsBuilt<Model, std::void_t<decltype(std::declval<ParamsOf<Model>&>().com),
                                          decltype(std::declval<ParamsOf<Model>&>().J),
                                          decltype(std::declval<ParamsOf<Model>&>().J_axial),
                                          decltype(std::declval<ParamsOf<Model>&>().tip)>> : std::true_type {};
}  // namespace detail

/// True when the model's Params describe the links as built (members com, J, J_axial, tip:
/// headers from ipgen with issue 21; NaN com or J means the homogeneous rod's value).
template <class Model>
inline constexpr bool has_links_as_built = detail::HasLinksAsBuilt<Model>::value;

/// True when the model defines kinetic_energy, potential_energy and dissipation (a header
/// specialised to a scene without an energy ledger omits them).
template <class Model>
inline constexpr bool has_energy = detail::HasEnergy<Model>::value;

namespace detail {
template <class Model, class = void>
struct HasWithRodLinks : std::false_type {};
template <class Model>
struct HasWithRodLinks<Model, std::void_t<decltype(Model::template with_rod_links<double>(
                                  std::declval<const ParamsOf<Model>&>()))>> : std::true_type {};
}  // namespace detail

/// `params` with every unset (NaN) com and J entry replaced by the homogeneous rod's value, once
/// (the model's with_rod_links): the right-hand side then reads them instead of computing the
/// rod values in every call. Models without it (rods only, or older headers) get `params`.
template <class Model>
ParamsOf<Model> with_rod_links(const ParamsOf<Model>& params) {
  if constexpr (detail::HasWithRodLinks<Model>::value) {
    return Model::template with_rod_links<double>(params);
  } else {
    return params;
  }
}

/// The first parameter whose value differs from the one folded into a specialised header
/// (its name, e.g. "m1"), or nullptr: general headers and model tags without check_folded fold
/// nothing.
template <class Model>
const char* folded_mismatch(const ParamsOf<Model>& params) {
  if constexpr (detail::HasCheckFolded<Model>::value) {
    return Model::template check_folded<double>(params);
  } else {
    return nullptr;
  }
}

namespace detail {
/// Compile-time sanity checks of a model tag, so a malformed one fails with a readable message.
template <class Model>
constexpr bool check_model() {
  if constexpr (!is_runtime<Model>) {
    static_assert(Model::kLinks >= 1, "a model needs at least one link");
    static_assert(Model::kDof == Model::kLinks + 1, "kDof must be kLinks + 1 (base + links)");
    static_assert(std::string_view(Model::kType) == "classical" || std::string_view(Model::kType) == "rotary",
                  "kType must be \"classical\" or \"rotary\"");
    static_assert(VectorOf<Model>::RowsAtCompileTime == Model::kDof, "Vector<Scalar> must have kDof rows");
  }
  return true;
}
}  // namespace detail

namespace detail {
template <class Model, class = void>
struct HasMassMatrix : std::false_type {};
template <class Model>
struct HasMassMatrix<Model, std::void_t<decltype(Model::template mass_matrix<double>(
                                std::declval<const VectorOf<Model>&>(), std::declval<const ParamsOf<Model>&>()))>>
    : std::true_type {};
}  // namespace detail

/// True when the model defines mass_matrix (a specialised header may omit it).
template <class Model>
inline constexpr bool has_mass_matrix = detail::HasMassMatrix<Model>::value;

namespace detail {
template <class Model, class = void>
struct HasMassAndBias : std::false_type {};
template <class Model>
struct HasMassAndBias<Model, std::void_t<decltype(Model::template mass_matrix<double>(
                                              std::declval<const VectorOf<Model>&>(), std::declval<const ParamsOf<Model>&>())),
                                          decltype(Model::template bias<double>(
                                              std::declval<const VectorOf<Model>&>(), std::declval<const VectorOf<Model>&>(),
                                              std::declval<const ParamsOf<Model>&>()))>> : std::true_type {};
}  // namespace detail

/// True when the model defines mass_matrix and bias (the energy swing-up and an
/// acceleration-driven base need them; a specialised header may omit them).
template <class Model>
inline constexpr bool has_mass_and_bias = detail::HasMassAndBias<Model>::value;

}  // namespace ipsim

namespace ipsim {

/// What a model may leave out (a header specialised to a scene omits some functions).
enum class Feature { mass_matrix, mass_and_bias, derivatives, energy };

/// Whether `Model` provides `feature`: known at compile time for a generated header, asked of
/// the loaded model for RuntimeModel (whose functions exist as calls but may have no target).
template <class Model>
bool provides(Feature feature) {
  bool compiled = false;
  switch (feature) {
    case Feature::mass_matrix: compiled = has_mass_matrix<Model>; break;
    case Feature::mass_and_bias: compiled = has_mass_and_bias<Model>; break;
    case Feature::derivatives: compiled = true; break;  // jacobian.hpp's has_derivatives decides for headers
    case Feature::energy: compiled = has_energy<Model>; break;
  }
  if constexpr (is_runtime<Model>) {
    return compiled && Model::provides(feature);
  } else {
    return compiled;
  }
}

}  // namespace ipsim

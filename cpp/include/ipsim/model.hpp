// What ipsim needs from a model tag type, and shorthands for its types.
//
// A model tag (e.g. ipgen::cdip::Model, written by the ipgen generator) provides
//   kLinks, kDof = kLinks + 1, kName, kType ("classical" | "rotary"), optionally kInertia
//   ("pivot" | "full" for rotary models, "" otherwise),
//   Params<Scalar>, Vector<Scalar>, and static function templates
//   mass_matrix, bias, gravity, n_matrix, forward_dynamics, kinetic_energy, potential_energy,
//   dissipation
// for the manipulator equation  M(θ) θ̈ + bias(θ, θ̇) = (u, 0, …, 0)ᵀ.
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

/// True for a pendulum on a cart (θ0 in metres, l[0] unused), false for a rotary (Furuta) base.
template <class Model>
constexpr bool is_classical() {
  return std::string_view(Model::kType) == "classical";
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
constexpr std::string_view inertia_of() {
  return detail::InertiaOf<Model>::value;
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
  static_assert(Model::kLinks >= 1, "a model needs at least one link");
  static_assert(Model::kDof == Model::kLinks + 1, "kDof must be kLinks + 1 (base + links)");
  static_assert(std::string_view(Model::kType) == "classical" || std::string_view(Model::kType) == "rotary",
                "kType must be \"classical\" or \"rotary\"");
  static_assert(VectorOf<Model>::RowsAtCompileTime == Model::kDof, "Vector<Scalar> must have kDof rows");
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

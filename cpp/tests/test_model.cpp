// The C++ test programs of ipsim's models. Two kinds, one source:
//
// test_models (compiled once, -DIPSIM_RUNTIME_MODEL): ipsim over ipsim::RuntimeModel, the model a
// model library (a generated C header and its adapter, --emit library) loaded at run time, as
// ipsim's simulator runs every generated model. ctest runs it once per model library:
//
//   test_models LIB                       the generic checks (model_checks.hpp, method_checks.hpp)
//   test_models LIB identities            the physics identities alone (large models)
//   test_models LIB stability ARGS...     the stability driver (cpp/stability/driver.hpp; ctest:
//                                         --quick), without the long-double and float scenarios
//
// test_model_<name> (compiled per model, -DIPGEN_MODEL_HEADER="name.hpp"
// -DIPGEN_MODEL=ipgen::name::Model): ipsim instantiated for a C++ header, for what needs the
// header's types at compile time:
//
//   test_model_<name>                     the generic checks, with IPGEN_MODEL_CHECKS (the stand-in)
//   test_model_<name> unit                the library's unit checks (unit_checks.hpp), and
//   test_model_<name> streaming           its streaming checks (streaming_checks.hpp): built for
//                                         the stand-in only (IPGEN_LIBRARY_CHECKS)
//   test_model_<name> stability ARGS...   the stability driver with the long-double and float
//                                         scenarios (precision.hpp), for models built with
//                                         IPGEN_STABILITY
#include <cstdio>
#include <string>

#if defined(IPSIM_RUNTIME_MODEL)
#include "ipsim/runtime_model.hpp"
#else
#include IPGEN_MODEL_HEADER
#endif

#include "method_checks.hpp"
#include "model_checks.hpp"
#ifdef IPGEN_LIBRARY_CHECKS
#include "streaming_checks.hpp"
#include "unit_checks.hpp"
#endif
#ifdef IPGEN_STABILITY
#include "driver.hpp"
#endif

namespace {

int unknown_arguments() {
  std::fprintf(stderr, "test_model: unknown arguments for this program (its suites: see test_model.cpp)\n");
  return 2;
}

/// Every generic check on `Model`.
template <class Model>
int all_checks() {
  ipsim_test::run_method_checks<Model>();
  return ipsim_test::run_model_checks<Model>();
}

}  // namespace

#if defined(IPSIM_RUNTIME_MODEL)

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fputs("usage: test_models LIB [identities | stability ARGS...]\n", stderr);
    return 2;
  }
  try {
    const ipsim::ModelLibrary library(argv[1]);
    const std::string suite = argc > 2 ? argv[2] : "";
    if (suite == "stability") return stability::driver::run<ipsim::RuntimeModel>(argc - 2, argv + 2);
    if (suite == "identities" && argc == 3) return ipsim_test::run_identity_checks<ipsim::RuntimeModel>();
    if (argc == 2) return all_checks<ipsim::RuntimeModel>();
    return unknown_arguments();
  } catch (const std::exception& e) {
    std::fprintf(stderr, "test_models: %s\n", e.what());
    return 2;
  }
}

#else

int main(int argc, char** argv) {
  const std::string suite = argc > 1 ? argv[1] : "";
#ifdef IPGEN_LIBRARY_CHECKS
  if (suite == "unit" && argc == 2) return ipsim_test::unit::run();
  if (suite == "streaming" && argc == 2) return ipsim_test::streaming::run();
#endif
#ifdef IPGEN_STABILITY
  if (suite == "stability") return stability::driver::run<IPGEN_MODEL>(argc - 1, argv + 1);
#endif
#ifdef IPGEN_MODEL_CHECKS
  if (argc == 1) return all_checks<IPGEN_MODEL>();
#endif
  return unknown_arguments();
}

#endif

// test_model_<name>: one model's C++ test program. CMake compiles it once per model with
// -DIPGEN_MODEL_HEADER="name.hpp" -DIPGEN_MODEL=ipgen::name::Model, and gathers here every ctest
// suite that needs ipsim instantiated for that model, so the model costs one compile of ipsim
// (about 30 s) instead of one per suite:
//
//   test_model_<name>                     the generic checks (model_checks.hpp, method_checks.hpp;
//                                         with IPGEN_IDENTITIES_ONLY the physics identities alone)
//   test_model_<name> unit                the library's unit checks (unit_checks.hpp), and
//   test_model_<name> streaming           its streaming checks (streaming_checks.hpp): built for
//                                         the stand-in only (IPGEN_LIBRARY_CHECKS)
//   test_model_<name> stability ARGS...   the stability driver (cpp/stability/driver.hpp; ctest:
//                                         --quick), for models built with IPGEN_STABILITY
#include <cstdio>
#include <string>

#include IPGEN_MODEL_HEADER

#include "method_checks.hpp"
#include "model_checks.hpp"
#ifdef IPGEN_LIBRARY_CHECKS
#include "streaming_checks.hpp"
#include "unit_checks.hpp"
#endif
#ifdef IPGEN_STABILITY
#include "driver.hpp"
#endif

int main(int argc, char** argv) {
  const std::string suite = argc > 1 ? argv[1] : "";
#ifdef IPGEN_LIBRARY_CHECKS
  if (suite == "unit" && argc == 2) return ipsim_test::unit::run();
  if (suite == "streaming" && argc == 2) return ipsim_test::streaming::run();
#endif
#ifdef IPGEN_STABILITY
  if (suite == "stability") return stability::driver::run<IPGEN_MODEL>(argc - 1, argv + 1);
#endif
  if (argc > 1) {
    std::fprintf(stderr, "test_model: unknown arguments for this model's program (its suites: see test_model.cpp)\n");
    return 2;
  }
#ifdef IPGEN_IDENTITIES_ONLY
  return ipsim_test::run_identity_checks<IPGEN_MODEL>();
#else
  ipsim_test::run_method_checks<IPGEN_MODEL>();
  return ipsim_test::run_model_checks<IPGEN_MODEL>();
#endif
}

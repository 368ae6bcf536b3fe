// Runs the generic ipsim checks (model_checks.hpp, method_checks.hpp) on one model; CMake compiles it once per model with
// -DIPGEN_MODEL_HEADER="name.hpp" -DIPGEN_MODEL=ipgen::name::Model.
#include IPGEN_MODEL_HEADER

#include "method_checks.hpp"
#include "model_checks.hpp"

int main() {
#ifdef IPGEN_IDENTITIES_ONLY
  return ipsim_test::run_identity_checks<IPGEN_MODEL>();
#else
  ipsim_test::run_method_checks<IPGEN_MODEL>();
  return ipsim_test::run_model_checks<IPGEN_MODEL>();
#endif
}

// Runs the generic ipsim checks on one model; CMake compiles it once per model with
// -DIPGEN_MODEL_HEADER="name.hpp" -DIPGEN_MODEL=ipgen::name::Model.
#include IPGEN_MODEL_HEADER

#include "model_checks.hpp"

int main() { return ipsim_test::run_model_checks<IPGEN_MODEL>(); }

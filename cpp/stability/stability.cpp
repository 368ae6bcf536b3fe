// stability_<model>: the stability driver (driver.hpp) as a program of its own, for `make stability`.
#ifndef IPGEN_MODEL_HEADER
#error "compile with -DIPGEN_MODEL_HEADER=\"name.hpp\" -DIPGEN_MODEL=ipgen::name::Model"
#endif
#include IPGEN_MODEL_HEADER

#include "driver.hpp"

int main(int argc, char** argv) { return stability::driver::run<IPGEN_MODEL>(argc, argv); }

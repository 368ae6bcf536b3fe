// Where ipsim's non-template functions are compiled: in every program that includes them (the
// default: ipsim is header-only), or once, in cpp/src/ipsim_core.cpp, when the program is built
// with -DIPSIM_SEPARATE_COMPILATION and linked with that object (the simulators of `ipgen run`,
// CMake's ipgen_add_simulator and the C++ tests do: these functions are about a third of one
// simulator's compile time, docs/testing.md).
//
// A header declares such a function, then defines it in a block guarded by IPSIM_DEFINITIONS with
// IPSIM_DECL in front: `inline` when header-only, nothing in ipsim_core.cpp (the one definition).
// Templates (everything that depends on the model) stay in the headers, but for the small models'
// LDLT solves, which the core instantiates (ipsim/ldlt.hpp).
#pragma once

#if defined(IPSIM_SEPARATE_COMPILATION) && !defined(IPSIM_CORE_SOURCE)
#define IPSIM_DEFINITIONS 0
#else
#define IPSIM_DEFINITIONS 1
#endif

#if defined(IPSIM_SEPARATE_COMPILATION)
#define IPSIM_DECL
#else
#define IPSIM_DECL inline
#endif

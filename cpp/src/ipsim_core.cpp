// ipsim's non-template functions (the scene reader, messages, coordinates, the estimators'
// algebra, eigenvalues), compiled once: a program built with -DIPSIM_SEPARATE_COMPILATION
// declares them only and links this object (ipsim/linkage.hpp). Everything that depends on the
// model stays a template in the headers.
#ifndef IPSIM_SEPARATE_COMPILATION
#define IPSIM_SEPARATE_COMPILATION
#endif
#define IPSIM_CORE_SOURCE

#include "ipsim/ipsim.hpp"
#include "ipsim/scene.hpp"
#include "ipsim/diagnostics.hpp"
#include "ipsim/eigenvalues.hpp"
#include "ipsim/sensors.hpp"

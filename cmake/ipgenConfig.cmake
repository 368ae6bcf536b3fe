# ipgen's CMake package: `find_package(ipgen CONFIG REQUIRED)` with -Dipgen_DIR=$(ipgen --cmake-dir)
# (this folder, installed with the Python package; in a checkout: its cmake/ folder).
#
# Provides ipgen::ipsim (the header-only simulator with Eigen, SUNDIALS and LAPACK), ipgen_ipsim_core
# (the same with ipsim's model-independent code compiled once, for several models) and the
# functions ipgen_add_model, ipgen_add_simulator and ipgen_add_scene (ipgen.cmake, which
# documents them and how the generator's Python is found: the one whose ipgen holds this file).
#
#   find_package(ipgen CONFIG REQUIRED)
#   ipgen_add_model(furuta TYPE rotary LINKS 2 INERTIA full)
#   add_executable(sim main.cpp)                    # #include "furuta.hpp", "ipsim/ipsim.hpp"
#   target_link_libraries(sim PRIVATE furuta ipgen::ipsim)

if(CMAKE_VERSION VERSION_LESS 3.25)
  message(FATAL_ERROR "ipgen needs CMake 3.25 or newer (this is ${CMAKE_VERSION})")
endif()
get_property(_ipgen_languages GLOBAL PROPERTY ENABLED_LANGUAGES)
if(NOT "CXX" IN_LIST _ipgen_languages)
  message(FATAL_ERROR "ipgen: enable C++ before find_package(ipgen), e.g. project(<name> LANGUAGES CXX)")
endif()
unset(_ipgen_languages)

include("${CMAKE_CURRENT_LIST_DIR}/ipgen.cmake")
ipgen_find_ipsim()
ipgen_ipsim_core()  # the target docs/simulator.md says to link for several models (built only then)
set(ipgen_FOUND TRUE)

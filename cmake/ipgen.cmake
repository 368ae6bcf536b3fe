# CMake functions of ipgen: generate model headers with the Python generator, build per-model
# simulators, and turn TOML scenes into resolved .cfg files. The one definition of these
# functions, used both by this repository's build (CMakeLists.txt includes this file) and by the
# CMake package installed with the Python package (ipgenConfig.cmake beside it includes it:
# `find_package(ipgen CONFIG REQUIRED)` with -Dipgen_DIR=$(ipgen --cmake-dir)).
#
#   ipgen_add_model(<target> TYPE rotary|classical LINKS <n> [INERTIA pivot|full] [NAME <name>])
#       Generates <name>.hpp (default name: <target>; INERTIA is for rotary models only, the
#       generator's default is pivot), and the C header and adapter of the C model interface
#       (<name>.h, <name>_model.c: --emit library), into ${CMAKE_CURRENT_BINARY_DIR}/ipgen_models
#       with `<python> -m ipgen`, and creates the INTERFACE target <target> that puts
#       that folder on the include path and links Eigen3::Eigen.
#
#   ipgen_add_simulator(<model target> [TARGET <executable>])
#       Builds an executable (default name simulate_<name>) from cpp/src/simulate.cpp for that
#       model. Any INTERFACE target with the property IPGEN_MODEL_NAME works as <model target>.
#       It links ipgen_ipsim_core.
#
#   ipgen_add_runtime_simulator(<model target> [TARGET <executable>])
#       The same executable without compiling ipsim for the model: the model's adapter to the C
#       model interface (<name>_model.c, which ipgen_add_model writes beside the header) linked
#       to ipsim's simulator compiled once (ipgen_ipsim_runtime). Needs the C language enabled
#       (project(... LANGUAGES CXX C)). A model costs about a second of compiling instead of half
#       a minute; the trajectories are the same.
#
#   ipgen_ipsim_runtime()
#       Creates (once per build) the object library ipgen_ipsim_runtime: cpp/src/simulate.cpp
#       compiled once with -DIPSIM_RUNTIME_MODEL (ipsim/runtime_model.hpp), linking
#       ipgen_ipsim_core; whatever links it, and an adapter, is a simulator.
#
#   ipgen_add_ipsim_simulate([TARGET <executable>])
#       The simulator `ipgen run` uses, built by this build (default target ipsim_simulate, file
#       ipsim-simulate): ipgen_ipsim_runtime alone, loading a model library at run time
#       (--model LIB). `ipgen run` takes it instead of compiling its own when $IPGEN_SIMULATOR
#       names it; it prints the digest of the ipsim sources it was built from
#       (--sources-digest), which `ipgen run` checks against its own.
#
#   ipgen_ipsim_core()
#       Creates (once per build) the static library ipgen_ipsim_core: ipsim's model-independent
#       functions compiled once (cpp/src/ipsim_core.cpp), with ipgen::ipsim and
#       -DIPSIM_SEPARATE_COMPILATION for whatever links it (cpp/include/ipsim/linkage.hpp).
#
#   ipgen_add_scene(<file.toml> [CFG_VAR <var>])
#       Reads the scene's [system] at configure time (`<python> -m ipgen --scene <file>
#       --describe`; a scene error stops CMake with the generator's one-line message; editing
#       the file re-runs CMake, so a changed [system] regenerates the header). Creates, on first use of the scene's model <name>, the model
#       target ipgen_model_<name> (ipgen_add_model) and its simulator simulate_<name>
#       (ipgen_add_simulator); scenes sharing a model must agree on its system. At build time,
#       `<python> -m ipgen --scene <file>` resolves the scene into
#       ${CMAKE_BINARY_DIR}/scenes/<stem>.cfg (re-run when the scene, the generator or its
#       templates change). Adds the target scene_<stem> (part of ALL: the .cfg and the simulator)
#       and run_scene_<stem> (runs it, writing ${CMAKE_BINARY_DIR}/scenes/<stem>.csv). <var>
#       receives the .cfg path. A fixed-pivot scene ([system] type = "fixed": the acrobot, the
#       pendubot, DFKI's rig) is a specialised model (its header is the scene's own: its driven
#       joints, rotors and controller), simulated through its C adapter: C must be enabled.
#
#   ipgen_find_ipsim()
#       Finds Eigen 3.4, SUNDIALS 6 and LAPACK (each missing one stops CMake naming its Debian
#       package) and defines the INTERFACE target ipgen::ipsim: the header-only simulator
#       (cpp/include) with everything it links. ipgenConfig.cmake calls it. Without a build type
#       (single-configuration generators, CMAKE_BUILD_TYPE empty) ipgen::ipsim adds -O2 -DNDEBUG,
#       so a simulator is optimised by default.
#
# The generator's <python> is the interpreter whose `ipgen` package holds this file: the first
# of ${IPGEN_PYTHON} (if set), the checkout's .venv, <prefix>/bin/python3 of the environment this
# file is installed in, and python3/python on PATH whose `python -m ipgen --cmake-dir` names the
# folder of this file. So a project that found the installed package runs the same ipgen, and
# nothing is written at install time. It is only looked for when a generating function is called.
#
# Layout (the same in the checkout and in the installed package ipgen/): cmake/ (this file),
# cpp/include/ipsim/ (the simulator), cpp/src/simulate.cpp (the simulator's command line),
# cpp/src/ipsim_core.cpp (ipsim's model-independent functions, compiled once: ipgen_ipsim_core).

include_guard(GLOBAL)

# The folder holding cmake/ and cpp/: the checkout, or the installed package's folder ipgen/.
cmake_path(GET CMAKE_CURRENT_LIST_DIR PARENT_PATH _IPGEN_ROOT)
set(_IPGEN_ROOT "${_IPGEN_ROOT}" CACHE INTERNAL "ipgen's folder (checkout or installed package)")
set(_IPGEN_CMAKE_DIR "${CMAKE_CURRENT_LIST_DIR}" CACHE INTERNAL "folder of ipgen.cmake")
# The generator's source: generator/ and templates/ in the checkout, the package itself installed.
if(EXISTS "${_IPGEN_ROOT}/generator/__init__.py")
  set(_IPGEN_CHECKOUT TRUE CACHE INTERNAL "ipgen.cmake is used from a checkout")
else()
  set(_IPGEN_CHECKOUT FALSE CACHE INTERNAL "ipgen.cmake is used from a checkout")
endif()

# Flags every target ipgen's functions create is compiled with: the warnings, and -Werror where
# IPGEN_WERROR is set (ipgen's own build: its CMakeLists.txt). A project that uses ipgen gets the
# warnings without failing on them: a newer compiler may warn where ipgen's tests' does not (as
# `ipgen run` compiles its simulators without -Werror).
function(ipgen_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(IPGEN_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
endfunction()

# Resolves IPGEN_PYTHON (cache): the interpreter whose ipgen owns this file, or stops with a
# message saying how to get one.
function(_ipgen_require_python)
  file(REAL_PATH "${_IPGEN_CMAKE_DIR}" wanted)
  # An interpreter this function found for another ipgen_DIR (the virtualenv moved or recreated,
  # another installation) is found again; one the user set (-DIPGEN_PYTHON) is kept.
  if(IPGEN_PYTHON AND "${IPGEN_PYTHON}" STREQUAL "${_IPGEN_PYTHON_FOUND}" AND
     NOT "${_IPGEN_PYTHON_FOR}" STREQUAL "${wanted}")
    unset(IPGEN_PYTHON CACHE)
    unset(IPGEN_PYTHON)
  endif()
  if(IPGEN_PYTHON)
    if(NOT EXISTS "${IPGEN_PYTHON}")
      message(FATAL_ERROR "ipgen: IPGEN_PYTHON=${IPGEN_PYTHON} does not exist")
    endif()
    return()
  endif()
  set(candidates "")
  if(_IPGEN_CHECKOUT)
    list(APPEND candidates "${_IPGEN_ROOT}/.venv/bin/python")
  else()
    # <prefix>/lib/pythonX.Y/site-packages/ipgen/cmake -> <prefix>/bin/python3 (a virtualenv, or
    # a system or user installation).
    cmake_path(GET _IPGEN_ROOT PARENT_PATH site_packages)
    cmake_path(GET site_packages PARENT_PATH python_lib)
    cmake_path(GET python_lib FILENAME python_version)
    cmake_path(GET python_lib PARENT_PATH lib)
    cmake_path(GET lib PARENT_PATH prefix)
    list(APPEND candidates "${prefix}/bin/${python_version}" "${prefix}/bin/python3" "${prefix}/bin/python")
  endif()
  foreach(name IN ITEMS python3 python)
    find_program(_IPGEN_PATH_PYTHON_${name} NAMES ${name} NO_CACHE)
    if(_IPGEN_PATH_PYTHON_${name})
      list(APPEND candidates "${_IPGEN_PATH_PYTHON_${name}}")
    endif()
  endforeach()
  set(tried "")
  foreach(candidate IN LISTS candidates)
    if(NOT EXISTS "${candidate}" OR candidate IN_LIST tried)
      continue()
    endif()
    list(APPEND tried "${candidate}")
    execute_process(
      COMMAND "${candidate}" -m ipgen --cmake-dir
      RESULT_VARIABLE status
      OUTPUT_VARIABLE cmake_dir
      ERROR_QUIET
      OUTPUT_STRIP_TRAILING_WHITESPACE)
    if(status EQUAL 0 AND EXISTS "${cmake_dir}")
      file(REAL_PATH "${cmake_dir}" cmake_dir)
      if(cmake_dir STREQUAL wanted)
        set(IPGEN_PYTHON "${candidate}" CACHE FILEPATH "Python interpreter that runs the ipgen generator")
        set(_IPGEN_PYTHON_FOUND "${candidate}" CACHE INTERNAL "IPGEN_PYTHON as found (not set by the user)")
        set(_IPGEN_PYTHON_FOR "${wanted}" CACHE INTERNAL "the ipgen cmake folder IPGEN_PYTHON was found for")
        return()
      endif()
    endif()
  endforeach()
  string(REPLACE ";" ", " tried "${tried}")
  if(_IPGEN_CHECKOUT)
    set(hint "Run `make venv` in ${_IPGEN_ROOT} first, or pass -DIPGEN_PYTHON=/path/to/python")
  else()
    set(hint "Pass -DIPGEN_PYTHON=/path/to/the/python that has ipgen installed")
  endif()
  message(FATAL_ERROR
    "ipgen: no Python whose `python -m ipgen --cmake-dir` is ${wanted} (tried: ${tried}). ${hint}.")
endfunction()

# Files whose change must re-run the generator.
function(_ipgen_generator_dependencies out_var)
  if(_IPGEN_CHECKOUT)
    file(GLOB_RECURSE sources CONFIGURE_DEPENDS "${_IPGEN_ROOT}/generator/*.py" "${_IPGEN_ROOT}/templates/*")
  else()
    file(GLOB_RECURSE sources CONFIGURE_DEPENDS "${_IPGEN_ROOT}/*.py" "${_IPGEN_ROOT}/templates/*")
  endif()
  set(${out_var} ${sources} PARENT_SCOPE)
endfunction()

# Where the generator runs: the checkout (as before), else the calling project's source folder.
function(_ipgen_working_directory out_var)
  if(_IPGEN_CHECKOUT)
    set(${out_var} "${_IPGEN_ROOT}" PARENT_SCOPE)
  else()
    set(${out_var} "${CMAKE_CURRENT_SOURCE_DIR}" PARENT_SCOPE)
  endif()
endfunction()

# Finds the simulator's dependencies and defines ipgen::ipsim (once per directory tree).
macro(ipgen_find_ipsim)
  if(NOT TARGET ipgen::ipsim)
    find_package(Eigen3 3.4 QUIET NO_MODULE)
    if(NOT Eigen3_FOUND)
      message(FATAL_ERROR "ipgen: Eigen 3.4 not found (needed by ipgen::ipsim and every model header); "
                          "install it (Debian: apt-get install libeigen3-dev) or pass -DEigen3_DIR=...")
    endif()
    find_package(SUNDIALS 6 QUIET COMPONENTS
      cvode arkode nvecserial sunmatrixdense sunlinsoldense sunnonlinsolfixedpoint)
    if(NOT SUNDIALS_FOUND)
      message(FATAL_ERROR "ipgen: SUNDIALS 6 (CVODE, ARKODE) not found (needed by ipgen::ipsim); "
                          "install it (Debian: apt-get install libsundials-dev) or pass -DSUNDIALS_DIR=...")
    endif()
    find_package(LAPACK QUIET)
    if(NOT LAPACK_FOUND)
      message(FATAL_ERROR "ipgen: LAPACK not found (ipgen::ipsim's numerical guards use it); "
                          "install it (Debian: apt-get install liblapack-dev)")
    endif()
    add_library(ipgen::ipsim INTERFACE IMPORTED)
    target_include_directories(ipgen::ipsim INTERFACE "${_IPGEN_ROOT}/cpp/include")
    target_compile_features(ipgen::ipsim INTERFACE cxx_std_17)
    target_link_libraries(ipgen::ipsim INTERFACE
      Eigen3::Eigen
      SUNDIALS::cvode
      SUNDIALS::arkode
      SUNDIALS::nvecserial
      SUNDIALS::sunmatrixdense
      SUNDIALS::sunlinsoldense
      SUNDIALS::sunnonlinsolfixedpoint
      LAPACK::LAPACK)
    # A single-configuration build without CMAKE_BUILD_TYPE compiles without optimisation, which
    # makes a simulator several times slower: whatever links ipsim is then built as in Release.
    get_property(_ipgen_multi_config GLOBAL PROPERTY GENERATOR_IS_MULTI_CONFIG)
    if(NOT _ipgen_multi_config AND NOT CMAKE_BUILD_TYPE)
      message(STATUS "ipgen: CMAKE_BUILD_TYPE is empty: targets linking ipgen::ipsim are built with -O2 -DNDEBUG")
      target_compile_options(ipgen::ipsim INTERFACE -O2)
      target_compile_definitions(ipgen::ipsim INTERFACE NDEBUG)
    endif()
  endif()
endmacro()

function(_ipgen_check_model_arguments function_name type links inertia)
  if(NOT type MATCHES "^(rotary|classical)$")
    message(FATAL_ERROR "${function_name}: TYPE must be rotary or classical, got `${type}`")
  endif()
  if(NOT links MATCHES "^[1-9][0-9]*$")
    message(FATAL_ERROR "${function_name}: LINKS must be a positive integer, got `${links}`")
  endif()
  if(inertia AND NOT inertia MATCHES "^(pivot|full)$")
    message(FATAL_ERROR "${function_name}: INERTIA must be pivot or full, got `${inertia}`")
  endif()
  if(inertia AND NOT type STREQUAL "rotary")
    message(FATAL_ERROR "${function_name}: INERTIA applies to rotary models only")
  endif()
endfunction()

function(ipgen_add_model target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "TYPE;LINKS;INERTIA;NAME" "")
  if(arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "ipgen_add_model(${target}): unexpected arguments ${arg_UNPARSED_ARGUMENTS}")
  endif()
  _ipgen_check_model_arguments("ipgen_add_model(${target})" "${arg_TYPE}" "${arg_LINKS}" "${arg_INERTIA}")
  set(name "${arg_NAME}")
  if(NOT name)
    set(name "${target}")
  endif()
  if(NOT name MATCHES "^[A-Za-z_][A-Za-z0-9_]*$")
    message(FATAL_ERROR "ipgen_add_model(${target}): NAME must be a C++ identifier, got `${name}`")
  endif()
  _ipgen_require_python()
  _ipgen_generator_dependencies(dependencies)
  _ipgen_working_directory(working_directory)

  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/ipgen_models")
  set(header "${out_dir}/${name}.hpp")
  # Two targets of one model name in one folder would write the same files (CMake's own error
  # names neither target): say which, and what to rename.
  string(SHA1 header_key "${header}")
  get_property(other GLOBAL PROPERTY "_IPGEN_MODEL_${header_key}")
  if(other)
    message(FATAL_ERROR "ipgen_add_model(${target}): target `${other}` already generates model `${name}` "
                        "in this folder; give one of them another NAME (or its scene another [system] name)")
  endif()
  set_property(GLOBAL PROPERTY "_IPGEN_MODEL_${header_key}" "${target}")
  set(inertia_option "")
  if(arg_INERTIA)
    set(inertia_option --inertia ${arg_INERTIA})
  endif()
  add_custom_command(
    OUTPUT "${header}" "${out_dir}/${name}.h" "${out_dir}/${name}_model.c"
    COMMAND "${IPGEN_PYTHON}" -m ipgen --type ${arg_TYPE} --links ${arg_LINKS} ${inertia_option}
            --name ${name} --emit cpp,library -o "${out_dir}"
    WORKING_DIRECTORY "${working_directory}"
    DEPENDS ${dependencies}
    COMMENT "ipgen: generating ${name}.hpp (${arg_TYPE}, links = ${arg_LINKS})"
    VERBATIM)

  add_library(${target} INTERFACE)
  # A private source makes the interface library own the generation step, so every target that
  # links it waits for the header.
  target_sources(${target} PRIVATE "${header}")
  target_include_directories(${target} INTERFACE "${out_dir}")
  ipgen_find_ipsim()  # Eigen3::Eigen
  target_link_libraries(${target} INTERFACE Eigen3::Eigen)
  set(inertia pivot)
  if(arg_INERTIA)
    set(inertia ${arg_INERTIA})
  endif()
  set_target_properties(${target} PROPERTIES
    IPGEN_MODEL_NAME "${name}"
    IPGEN_MODEL_HEADER "${header}"
    IPGEN_MODEL_ADAPTER "${out_dir}/${name}_model.c"
    IPGEN_MODEL_SYSTEM "type=${arg_TYPE} links=${arg_LINKS} inertia=${inertia}")
endfunction()

# The static library ipgen_ipsim_core (once per build): ipsim's model-independent functions
# compiled once, with ipgen::ipsim and -DIPSIM_SEPARATE_COMPILATION for whatever links it
# (cpp/include/ipsim/linkage.hpp). Every simulator links it instead of compiling them again.
function(ipgen_ipsim_core)
  if(NOT TARGET ipgen_ipsim_core)
    ipgen_find_ipsim()
    # Built only for a target that links it (find_package creates it for every project).
    add_library(ipgen_ipsim_core STATIC EXCLUDE_FROM_ALL "${_IPGEN_ROOT}/cpp/src/ipsim_core.cpp")
    target_link_libraries(ipgen_ipsim_core PUBLIC ipgen::ipsim)
    target_compile_definitions(ipgen_ipsim_core PUBLIC IPSIM_SEPARATE_COMPILATION)
    ipgen_target_warnings(ipgen_ipsim_core)
  endif()
endfunction()

# The object library ipgen_ipsim_runtime (once per build): ipsim's simulator compiled once for
# every model (cpp/src/simulate.cpp, -DIPSIM_RUNTIME_MODEL), linking ipgen_ipsim_core.
function(ipgen_ipsim_runtime)
  if(NOT TARGET ipgen_ipsim_runtime)
    ipgen_ipsim_core()
    _ipgen_ipsim_sources_digest(digest)
    add_library(ipgen_ipsim_runtime OBJECT "${_IPGEN_ROOT}/cpp/src/simulate.cpp")
    target_link_libraries(ipgen_ipsim_runtime PUBLIC ipgen_ipsim_core ${CMAKE_DL_LIBS})
    target_compile_definitions(ipgen_ipsim_runtime PRIVATE IPSIM_RUNTIME_MODEL IPSIM_SOURCES_DIGEST="${digest}")
    ipgen_target_warnings(ipgen_ipsim_runtime)
  endif()
endfunction()

# The SHA-256 of ipsim's sources as ipgen computes it (generator/pipeline/simulator.py,
# sources_digest): of "NAME\nSHA256\n" per file, in this order. Editing one re-runs CMake.
function(_ipgen_ipsim_sources_digest out_var)
  set(include "${_IPGEN_ROOT}/cpp/include")
  if(CMAKE_SCRIPT_MODE_FILE)  # cmake -P (tests/test_external_simulator.py): no configure to re-run
    file(GLOB headers LIST_DIRECTORIES false "${include}/ipsim/*.hpp")
  else()
    file(GLOB headers LIST_DIRECTORIES false CONFIGURE_DEPENDS "${include}/ipsim/*.hpp")
  endif()
  list(SORT headers)
  set(files "${_IPGEN_ROOT}/cpp/src/simulate.cpp" "${_IPGEN_ROOT}/cpp/src/ipsim_core.cpp"
            "${include}/ipgen_model.h" "${include}/ipgen_loop.h" "${include}/ipgen_mpc.h" ${headers})
  set(text "")
  foreach(file IN LISTS files)
    file(SHA256 "${file}" sum)
    cmake_path(GET file FILENAME name)
    string(APPEND text "${name}\n${sum}\n")
  endforeach()
  string(SHA256 digest "${text}")
  if(NOT CMAKE_SCRIPT_MODE_FILE)
    set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${files})
  endif()
  set(${out_var} "${digest}" PARENT_SCOPE)
endfunction()

function(ipgen_add_ipsim_simulate)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "TARGET" "")
  set(simulator ipsim_simulate)
  if(arg_TARGET)
    set(simulator ${arg_TARGET})
  endif()
  ipgen_ipsim_runtime()
  add_executable(${simulator})
  target_link_libraries(${simulator} PRIVATE ipgen_ipsim_runtime)
  set_target_properties(${simulator} PROPERTIES OUTPUT_NAME ipsim-simulate)
endfunction()

function(ipgen_add_runtime_simulator model_target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "TARGET" "")
  get_target_property(name ${model_target} IPGEN_MODEL_NAME)
  get_target_property(adapter ${model_target} IPGEN_MODEL_ADAPTER)
  if(NOT name OR NOT adapter)
    message(FATAL_ERROR "ipgen_add_runtime_simulator: ${model_target} is not an ipgen model target with an "
                        "adapter (no IPGEN_MODEL_NAME or IPGEN_MODEL_ADAPTER: make it with ipgen_add_model)")
  endif()
  get_property(languages GLOBAL PROPERTY ENABLED_LANGUAGES)
  if(NOT "C" IN_LIST languages)
    message(FATAL_ERROR "ipgen_add_runtime_simulator(${model_target}): the model's adapter is C: enable the "
                        "C language (project(... LANGUAGES CXX C))")
  endif()
  set(simulator simulate_${name})
  if(arg_TARGET)
    set(simulator ${arg_TARGET})
  endif()
  ipgen_ipsim_runtime()
  cmake_path(GET adapter PARENT_PATH adapter_dir)
  add_executable(${simulator} "${adapter}")
  set_target_properties(${simulator} PROPERTIES C_STANDARD 99 C_STANDARD_REQUIRED ON C_EXTENSIONS OFF LINKER_LANGUAGE CXX)
  target_include_directories(${simulator} PRIVATE "${adapter_dir}" "${_IPGEN_ROOT}/cpp/include")
  target_link_libraries(${simulator} PRIVATE ipgen_ipsim_runtime m)
  # The model's functions are the adapter's only entry point: found through ipgen_model_get.
  target_compile_options(${simulator} PRIVATE $<$<COMPILE_LANGUAGE:C>:-Wall -Wextra -Wpedantic>)
  if(IPGEN_WERROR)
    target_compile_options(${simulator} PRIVATE $<$<COMPILE_LANGUAGE:C>:-Werror>)
  endif()
  add_dependencies(${simulator} ${model_target})
endfunction()

function(ipgen_add_simulator model_target)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "TARGET" "")
  get_target_property(name ${model_target} IPGEN_MODEL_NAME)
  if(NOT name)
    message(FATAL_ERROR "ipgen_add_simulator: ${model_target} is not an ipgen model target (no IPGEN_MODEL_NAME)")
  endif()
  set(simulator simulate_${name})
  if(arg_TARGET)
    set(simulator ${arg_TARGET})
  endif()
  add_executable(${simulator} "${_IPGEN_ROOT}/cpp/src/simulate.cpp")
  ipgen_ipsim_core()
  target_link_libraries(${simulator} PRIVATE ipgen_ipsim_core ${model_target})
  target_compile_definitions(${simulator} PRIVATE
    IPGEN_MODEL_HEADER="${name}.hpp"
    IPGEN_MODEL=ipgen::${name}::Model)
  ipgen_target_warnings(${simulator})
endfunction()

# Sets <prefix>_NAME, _TYPE, _LINKS, _INERTIA and _STEM from `ipgen --scene <scene> --describe`,
# or stops CMake with the generator's one-line error.
function(_ipgen_describe_scene scene prefix)
  _ipgen_working_directory(working_directory)
  execute_process(
    COMMAND "${IPGEN_PYTHON}" -m ipgen --scene "${scene}" --describe
    WORKING_DIRECTORY "${working_directory}"
    RESULT_VARIABLE status
    OUTPUT_VARIABLE description
    ERROR_VARIABLE errors
    OUTPUT_STRIP_TRAILING_WHITESPACE
    ERROR_STRIP_TRAILING_WHITESPACE)
  # A leading space keeps each line as it is: CMake would otherwise re-wrap the message.
  string(REPLACE "\n" "\n " errors " ${errors}")
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "${errors}")
  endif()
  if(NOT errors STREQUAL " ")
    message(WARNING "${errors}")
  endif()
  set(pattern "^name=([A-Za-z0-9_]+) type=(classical|rotary|fixed) links=([0-9]+) inertia=(pivot|full) stem=([^ ]+) specialise=(true|false)$")
  if(NOT description MATCHES "${pattern}")
    message(FATAL_ERROR "ipgen: unexpected output of `${IPGEN_PYTHON} -m ipgen --scene ${scene} "
                        "--describe`: `${description}`")
  endif()
  set(${prefix}_NAME "${CMAKE_MATCH_1}" PARENT_SCOPE)
  set(${prefix}_TYPE "${CMAKE_MATCH_2}" PARENT_SCOPE)
  set(${prefix}_LINKS "${CMAKE_MATCH_3}" PARENT_SCOPE)
  set(${prefix}_INERTIA "${CMAKE_MATCH_4}" PARENT_SCOPE)
  set(${prefix}_STEM "${CMAKE_MATCH_5}" PARENT_SCOPE)
  set(${prefix}_SPECIALISE "${CMAKE_MATCH_6}" PARENT_SCOPE)
endfunction()

function(ipgen_add_scene scene_file)
  cmake_parse_arguments(PARSE_ARGV 1 arg "" "CFG_VAR" "")
  if(arg_UNPARSED_ARGUMENTS)
    message(FATAL_ERROR "usage: ipgen_add_scene(<file.toml> [CFG_VAR <var>]), "
                        "got unexpected arguments ${arg_UNPARSED_ARGUMENTS}")
  endif()
  cmake_path(ABSOLUTE_PATH scene_file BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" OUTPUT_VARIABLE scene)
  _ipgen_require_python()
  ipgen_find_ipsim()
  # Editing the scene re-runs CMake, so a changed [system] reaches the model target below.
  set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS "${scene}")
  _ipgen_describe_scene("${scene}" system)
  set(name "${system_NAME}")
  set(stem "${system_STEM}")
  if(TARGET scene_${stem})
    get_target_property(other scene_${stem} IPGEN_SCENE_FILE)
    message(FATAL_ERROR "ipgen_add_scene(${scene}): a scene named ${stem} was already added (${other}); "
                        "rename one of the files")
  endif()

  set(model_target ipgen_model_${name})
  set(work_dir "${CMAKE_CURRENT_BINARY_DIR}/ipgen_scenes/${stem}")
  if(system_SPECIALISE)
    # A specialised model belongs to its scene: its header is the one `--scene` writes (it
    # depends on the scene's parameters), so a changed value regenerates it.
    if(TARGET ${model_target})
      message(FATAL_ERROR "ipgen_add_scene(${scene}): model `${name}` already exists, and this scene's "
                          "specialised model needs a name of its own; change its [system] name")
    endif()
    add_library(${model_target} INTERFACE)
    target_sources(${model_target} PRIVATE "${work_dir}/${name}.hpp")
    target_include_directories(${model_target} INTERFACE "${work_dir}")
    target_link_libraries(${model_target} INTERFACE Eigen3::Eigen)
    set_target_properties(${model_target} PROPERTIES
      IPGEN_MODEL_NAME "${name}"
      IPGEN_MODEL_HEADER "${work_dir}/${name}.hpp"
      IPGEN_MODEL_ADAPTER "${work_dir}/${name}_model.c"
      IPGEN_MODEL_SYSTEM "specialised by ${scene}")
  else()
    # A general model: created by the first scene that uses it; later scenes must describe the
    # same system.
    set(wanted "type=${system_TYPE} links=${system_LINKS} inertia=${system_INERTIA}")
    if(NOT TARGET ${model_target})
      set(inertia_args "")
      if(system_TYPE STREQUAL "rotary")
        set(inertia_args INERTIA ${system_INERTIA})
      endif()
      ipgen_add_model(${model_target} TYPE ${system_TYPE} LINKS ${system_LINKS} ${inertia_args} NAME ${name})
    endif()
    get_target_property(existing ${model_target} IPGEN_MODEL_SYSTEM)
    if(NOT existing STREQUAL wanted)
      message(FATAL_ERROR "ipgen_add_scene(${scene}): model `${name}` is already defined as ${existing}, "
                          "this scene says ${wanted}; give the scene another [system] name")
    endif()
  endif()
  if(NOT TARGET simulate_${name})
    # ipsim compiled once and the model's C adapter when the project has C, else ipsim compiled
    # for the model's C++ header (a project of only CXX, as before): the same trajectories.
    get_property(languages GLOBAL PROPERTY ENABLED_LANGUAGES)
    if("C" IN_LIST languages)
      ipgen_add_runtime_simulator(${model_target})
    elseif(system_TYPE STREQUAL "fixed")
      # A fixed-pivot chain is simulated through its C adapter only (as `ipgen run` does).
      message(FATAL_ERROR "ipgen_add_scene(${scene}): a fixed-pivot chain's simulator links its C adapter: "
                          "enable C in the project (project(... LANGUAGES CXX C))")
    else()
      ipgen_add_simulator(${model_target})
    endif()
  endif()

  # The generator writes the scene's model header next to its .cfg. Headers come from the model
  # target, and two scenes of one model must not claim the same file: generate into a folder of
  # the scene's own, then move the .cfg to its documented place.
  _ipgen_generator_dependencies(dependencies)
  _ipgen_working_directory(working_directory)
  set(cfg "${CMAKE_BINARY_DIR}/scenes/${stem}.cfg")
  set(csv "${CMAKE_BINARY_DIR}/scenes/${stem}.csv")
  # The header `--scene` writes is this scene's model when specialised, else a spare copy.
  set(outputs "${cfg}")
  set(byproducts "")
  set(model_files "${work_dir}/${name}.hpp" "${work_dir}/${name}.h" "${work_dir}/${name}_model.c")
  if(system_SPECIALISE)
    list(APPEND outputs ${model_files})
  else()
    list(APPEND byproducts ${model_files})
  endif()
  add_custom_command(
    OUTPUT ${outputs}
    BYPRODUCTS ${byproducts}
    COMMAND "${IPGEN_PYTHON}" -m ipgen --scene "${scene}" --emit cpp,library -o "${work_dir}"
    COMMAND "${CMAKE_COMMAND}" -E make_directory "${CMAKE_BINARY_DIR}/scenes"
    COMMAND "${CMAKE_COMMAND}" -E rename "${work_dir}/${stem}.cfg" "${cfg}"
    WORKING_DIRECTORY "${working_directory}"
    DEPENDS "${scene}" ${dependencies}
    COMMENT "ipgen: resolving scene ${stem}"
    VERBATIM)
  add_custom_target(scene_${stem} ALL DEPENDS "${cfg}" simulate_${name})
  set_target_properties(scene_${stem} PROPERTIES
    IPGEN_SCENE_FILE "${scene}"
    IPGEN_SCENE_CFG "${cfg}"
    IPGEN_SCENE_MODEL "${name}")
  add_custom_target(run_scene_${stem}
    COMMAND simulate_${name} "${cfg}" --csv "${csv}"
    DEPENDS "${cfg}" simulate_${name}
    COMMENT "ipgen: simulating scene ${stem}"
    VERBATIM)
  if(arg_CFG_VAR)
    set(${arg_CFG_VAR} "${cfg}" PARENT_SCOPE)
  endif()
endfunction()

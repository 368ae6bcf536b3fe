# CMake helpers for ipgen: generate model headers with the Python generator, build per-model
# simulators, and turn TOML scenes into resolved .cfg files.
#
#   ipgen_add_model(<target> TYPE rotary|classical LINKS <n> [INERTIA pivot|full] [NAME <name>])
#       Generates <name>.hpp (default name: <target>; INERTIA is for rotary models only, the
#       generator's default is pivot) into ${CMAKE_CURRENT_BINARY_DIR}/ipgen_models
#       with `${IPGEN_PYTHON} -m generator`, and creates the INTERFACE target <target> that puts
#       that folder on the include path and links Eigen3::Eigen.
#
#   ipgen_add_simulator(<model target> [TARGET <executable>])
#       Builds an executable (default name simulate_<name>) from cpp/src/simulate.cpp for that
#       model. Any INTERFACE target with the property IPGEN_MODEL_NAME works as <model target>.
#
#   ipgen_add_scene(SCENE <file.toml> MODEL <name> TYPE rotary|classical LINKS <n>
#                   [INERTIA pivot|full] [CFG_VAR <var>])
#       Runs `${IPGEN_PYTHON} -m generator --scene <file> -o <dir>` to write <dir>/<stem>.cfg.
#       CMake cannot read TOML, so the scene's model is restated here; its header comes from
#       ipgen_add_model(ipgen_model_<name> ...) and its simulator from ipgen_add_simulator (both
#       created on first use; the scene's model must agree with MODEL/TYPE/LINKS/INERTIA, which
#       the simulator checks when it reads the .cfg). Adds the target scene_<stem> (part of ALL:
#       builds the .cfg and the simulator) and run_scene_<stem> (runs it, writing
#       <dir>/<stem>.csv). <var> receives the .cfg path; <dir> is
#       ${CMAKE_CURRENT_BINARY_DIR}/ipgen_scenes/<stem>.
#
# The generator's Python is ${IPGEN_PYTHON}: set it with -DIPGEN_PYTHON=..., otherwise the
# repository's .venv is used. It is only looked for when one of these functions is called.

include_guard(GLOBAL)

# The repository root, wherever this file is included from.
cmake_path(GET CMAKE_CURRENT_LIST_DIR PARENT_PATH _IPGEN_ROOT)
set(_IPGEN_ROOT "${_IPGEN_ROOT}" CACHE INTERNAL "ipgen source root")

# Flags every target of the project is compiled with.
function(ipgen_target_warnings target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Werror)
endfunction()

# Resolves IPGEN_PYTHON (cache) or stops with a message saying how to get one.
function(_ipgen_require_python)
  if(IPGEN_PYTHON)
    if(NOT EXISTS "${IPGEN_PYTHON}")
      message(FATAL_ERROR "ipgen: IPGEN_PYTHON=${IPGEN_PYTHON} does not exist")
    endif()
    return()
  endif()
  set(venv_python "${_IPGEN_ROOT}/.venv/bin/python")
  if(EXISTS "${venv_python}")
    set(IPGEN_PYTHON "${venv_python}" CACHE FILEPATH "Python interpreter that runs the ipgen generator")
  else()
    message(FATAL_ERROR
      "ipgen: no Python environment for the generator (looked for ${venv_python}). "
      "Run `make test` or `make venv` first, or pass -DIPGEN_PYTHON=/path/to/python.")
  endif()
endfunction()

# Files whose change must re-run the generator.
function(_ipgen_generator_dependencies out_var)
  file(GLOB_RECURSE sources CONFIGURE_DEPENDS
    "${_IPGEN_ROOT}/generator/*.py"
    "${_IPGEN_ROOT}/templates/*")
  set(${out_var} ${sources} PARENT_SCOPE)
endfunction()

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

  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/ipgen_models")
  set(header "${out_dir}/${name}.hpp")
  set(inertia_option "")
  if(arg_INERTIA)
    set(inertia_option --inertia ${arg_INERTIA})
  endif()
  add_custom_command(
    OUTPUT "${header}"
    COMMAND "${IPGEN_PYTHON}" -m generator --type ${arg_TYPE} --links ${arg_LINKS} ${inertia_option}
            --name ${name} -o "${out_dir}"
    WORKING_DIRECTORY "${_IPGEN_ROOT}"
    DEPENDS ${dependencies}
    COMMENT "ipgen: generating ${name}.hpp (${arg_TYPE}, links = ${arg_LINKS})"
    VERBATIM)

  add_library(${target} INTERFACE)
  # A private source makes the interface library own the generation step, so every target that
  # links it waits for the header.
  target_sources(${target} PRIVATE "${header}")
  target_include_directories(${target} INTERFACE "${out_dir}")
  target_link_libraries(${target} INTERFACE Eigen3::Eigen)
  set_target_properties(${target} PROPERTIES
    IPGEN_MODEL_NAME "${name}"
    IPGEN_MODEL_HEADER "${header}")
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
  target_link_libraries(${simulator} PRIVATE ipgen::ipsim ${model_target})
  target_compile_definitions(${simulator} PRIVATE
    IPGEN_MODEL_HEADER="${name}.hpp"
    IPGEN_MODEL=ipgen::${name}::Model)
  ipgen_target_warnings(${simulator})
endfunction()

function(ipgen_add_scene)
  cmake_parse_arguments(PARSE_ARGV 0 arg "" "SCENE;MODEL;TYPE;LINKS;INERTIA;CFG_VAR" "")
  if(arg_UNPARSED_ARGUMENTS OR NOT arg_SCENE OR NOT arg_MODEL)
    message(FATAL_ERROR "usage: ipgen_add_scene(SCENE <file.toml> MODEL <name> TYPE rotary|classical "
                        "LINKS <n> [INERTIA pivot|full] [CFG_VAR <var>])")
  endif()
  _ipgen_check_model_arguments("ipgen_add_scene(${arg_SCENE})" "${arg_TYPE}" "${arg_LINKS}" "${arg_INERTIA}")
  cmake_path(ABSOLUTE_PATH arg_SCENE BASE_DIRECTORY "${CMAKE_CURRENT_SOURCE_DIR}" OUTPUT_VARIABLE scene)
  cmake_path(GET scene STEM stem)

  set(model_target ipgen_model_${arg_MODEL})
  if(NOT TARGET ${model_target})
    set(inertia_args "")
    if(arg_INERTIA)
      set(inertia_args INERTIA ${arg_INERTIA})
    endif()
    ipgen_add_model(${model_target} TYPE ${arg_TYPE} LINKS ${arg_LINKS} ${inertia_args} NAME ${arg_MODEL})
  endif()
  if(NOT TARGET simulate_${arg_MODEL})
    ipgen_add_simulator(${model_target})
  endif()

  _ipgen_require_python()
  _ipgen_generator_dependencies(dependencies)
  # Each scene gets its own folder: the generator also writes the model header there, and two
  # scenes of one model must not claim the same output file.
  set(out_dir "${CMAKE_CURRENT_BINARY_DIR}/ipgen_scenes/${stem}")
  set(cfg "${out_dir}/${stem}.cfg")
  set(csv "${out_dir}/${stem}.csv")
  add_custom_command(
    OUTPUT "${cfg}"
    BYPRODUCTS "${out_dir}/${arg_MODEL}.hpp"
    COMMAND "${IPGEN_PYTHON}" -m generator --scene "${scene}" -o "${out_dir}"
    WORKING_DIRECTORY "${_IPGEN_ROOT}"
    DEPENDS "${scene}" ${dependencies}
    COMMENT "ipgen: resolving scene ${stem}"
    VERBATIM)
  add_custom_target(scene_${stem} ALL DEPENDS "${cfg}" simulate_${arg_MODEL})
  set_target_properties(scene_${stem} PROPERTIES IPGEN_SCENE_CFG "${cfg}" IPGEN_SCENE_MODEL "${arg_MODEL}")
  add_custom_target(run_scene_${stem}
    COMMAND simulate_${arg_MODEL} "${cfg}" --csv "${csv}"
    DEPENDS "${cfg}" simulate_${arg_MODEL}
    COMMENT "ipgen: simulating scene ${stem}"
    VERBATIM)
  if(arg_CFG_VAR)
    set(${arg_CFG_VAR} "${cfg}" PARENT_SCOPE)
  endif()
endfunction()

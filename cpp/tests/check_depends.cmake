# ctest helper: fails unless Ninja's build graph makes OUTPUT depend on INPUT, i.e. editing INPUT
# regenerates OUTPUT. Usage: cmake -DNINJA=... -DBUILD_DIR=... -DOUTPUT=... -DINPUT=... -P check_depends.cmake
execute_process(COMMAND "${NINJA}" -C "${BUILD_DIR}" -t query "${OUTPUT}"
                OUTPUT_VARIABLE graph RESULT_VARIABLE status)
if(NOT status EQUAL 0)
  message(FATAL_ERROR "ninja -t query ${OUTPUT} failed:\n${graph}")
endif()
string(FIND "${graph}" "${INPUT}" found)
if(found EQUAL -1)
  message(FATAL_ERROR "${OUTPUT} does not depend on ${INPUT}:\n${graph}")
endif()
message(STATUS "${OUTPUT} depends on ${INPUT}")

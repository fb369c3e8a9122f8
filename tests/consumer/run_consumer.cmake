# Driver for the consumer test (see CMakeLists.txt next to this file). Run with cmake -P and
#   MAIN_BUILD_DIR       the vinci build tree to install
#   PREFIX               where to install it (removed first)
#   CONSUMER_SOURCE_DIR  the consumer project
#   CONSUMER_BINARY_DIR  its build tree (removed first)
#   CONFIG               build configuration (may be empty)
#   GENERATOR, CXX_COMPILER, CXX_FLAGS, LINK_FLAGS   passed to the consumer's configure
cmake_minimum_required(VERSION 3.22)

foreach(var MAIN_BUILD_DIR PREFIX CONSUMER_SOURCE_DIR CONSUMER_BINARY_DIR)
  if(NOT DEFINED ${var} OR "${${var}}" STREQUAL "")
    message(FATAL_ERROR "run_consumer.cmake: -D ${var}=... is required")
  endif()
endforeach()

function(run step)
  message(STATUS "consumer: ${step}: ${ARGN}")
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "consumer: ${step} failed (${rc})")
  endif()
endfunction()

file(REMOVE_RECURSE "${PREFIX}" "${CONSUMER_BINARY_DIR}")

set(config_args "")
if(CONFIG)
  set(config_args --config "${CONFIG}")
endif()
run(install "${CMAKE_COMMAND}" --install "${MAIN_BUILD_DIR}" --prefix "${PREFIX}" ${config_args})

set(configure_args
  -S "${CONSUMER_SOURCE_DIR}" -B "${CONSUMER_BINARY_DIR}"
  "-DCMAKE_PREFIX_PATH=${PREFIX}"
  # Only the install tree may provide vinci: not the user package registry, not the build tree.
  -DCMAKE_FIND_USE_PACKAGE_REGISTRY=OFF
  -DCMAKE_FIND_USE_SYSTEM_PACKAGE_REGISTRY=OFF)
if(GENERATOR)
  list(APPEND configure_args -G "${GENERATOR}")
endif()
if(CXX_COMPILER)
  list(APPEND configure_args "-DCMAKE_CXX_COMPILER=${CXX_COMPILER}")
endif()
if(CONFIG)
  list(APPEND configure_args "-DCMAKE_BUILD_TYPE=${CONFIG}")
endif()
if(CXX_FLAGS)
  list(APPEND configure_args "-DCMAKE_CXX_FLAGS=${CXX_FLAGS}")
endif()
if(LINK_FLAGS)
  list(APPEND configure_args "-DCMAKE_EXE_LINKER_FLAGS=${LINK_FLAGS}")
endif()
run(configure "${CMAKE_COMMAND}" ${configure_args})

# The consumer must have found the freshly installed package, nothing else.
file(STRINGS "${CONSUMER_BINARY_DIR}/CMakeCache.txt" vinci_dir_line REGEX "^vinci_DIR:")
string(REGEX REPLACE "^vinci_DIR:[A-Z]+=" "" vinci_dir "${vinci_dir_line}")
file(REAL_PATH "${PREFIX}" prefix_real)
file(REAL_PATH "${vinci_dir}" vinci_dir_real)
string(FIND "${vinci_dir_real}/" "${prefix_real}/" pos)
if(NOT pos EQUAL 0)
  message(FATAL_ERROR "consumer: found vinci in '${vinci_dir}', expected under '${PREFIX}'")
endif()
message(STATUS "consumer: vinci_DIR = ${vinci_dir}")

# The installed command-line tool, if this build installs it, must start.
if(EXISTS "${PREFIX}/bin/vinci")
  run(installed-cli "${PREFIX}/bin/vinci" --version)
endif()

run(build "${CMAKE_COMMAND}" --build "${CONSUMER_BINARY_DIR}" ${config_args})

set(exe "${CONSUMER_BINARY_DIR}/vinci_consumer")
if(NOT EXISTS "${exe}" AND CONFIG)
  set(exe "${CONSUMER_BINARY_DIR}/${CONFIG}/vinci_consumer")
endif()
run(run "${exe}")
message(STATUS "consumer: passed")

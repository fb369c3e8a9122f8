# `mpirun -np 2 vinci design|field` (docs/design.md, "MPI"; docs/field.md): the same results as
# one process, with both ranks working (mpi_compare.cmake). Included by tests/cli/CMakeLists.txt;
# only when vinci was built with MPI. Open MPI refuses to run as root unless told it may.
if(NOT VINCI_HAVE_MPI)
  return()
endif()
find_program(VINCI_MPIRUN NAMES mpirun mpiexec HINTS ${MPIEXEC_EXECUTABLE})
if(NOT VINCI_MPIRUN)
  message(STATUS "vinci: no mpirun: the MPI tests are skipped")
  return()
endif()
set(VINCI_MPI_ENV OMPI_ALLOW_RUN_AS_ROOT=1 OMPI_ALLOW_RUN_AS_ROOT_CONFIRM=1)

# name; mode; runs (ranks:threads, the first the reference); arguments
set(VINCI_MPI_CASES
  "design|design|1:1%%1:2%%2:1|design%%${VINCI_CLI_DATA}/design_mpi.yaml%%--quiet"
  "design_ipopt|design|1:1%%2:1|design%%${VINCI_CLI_DATA}/design_mpi.yaml%%--optimizer%%ipopt%%--budget%%120%%--quiet"
  "field|field|1:1%%2:1%%2:2|field%%${PROJECT_SOURCE_DIR}/examples/scenes/plate_tilt_planar.yaml%%--grid%%8%%--cycles%%3%%--average-cycles%%1")
foreach(case IN LISTS VINCI_MPI_CASES)
  string(REPLACE "|" ";" fields "${case}")
  list(GET fields 0 name)
  list(GET fields 1 mode)
  list(GET fields 2 runs)
  list(GET fields 3 args)
  add_test(NAME cli_mpi_${name}
           COMMAND ${CMAKE_COMMAND} -E env ${VINCI_MPI_ENV}
                   ${CMAKE_COMMAND} -DVINCI=$<TARGET_FILE:vinci> -DMPIRUN=${VINCI_MPIRUN}
                   -DMODE=${mode} -DRUNS=${runs} -DARGS=${args}
                   -DOUT=${VINCI_CLI_OUT}/mpi_${name}
                   -P ${CMAKE_CURRENT_SOURCE_DIR}/mpi_compare.cmake)
  set_tests_properties(cli_mpi_${name} PROPERTIES LABELS fast TIMEOUT 300 RUN_SERIAL ON)
endforeach()

# Bad input under mpirun: one clean error (from rank 0) and exit 1, no hang.
add_test(NAME cli_mpi_design_bad_spec
         COMMAND ${CMAKE_COMMAND} -E env ${VINCI_MPI_ENV}
                 ${CMAKE_COMMAND} -DVINCI=${VINCI_MPIRUN} -DEXPECT_EXIT=1
                 "-DARGS=-np%%2%%--oversubscribe%%$<TARGET_FILE:vinci>%%design%%${PROJECT_SOURCE_DIR}/tests/design/data/bad_spec.yaml%%--out%%${VINCI_CLI_OUT}/mpi_design_bad"
                 "-DSTDERR_MATCHES=bad_spec\\.yaml:4: parameters\\[0\\]\\.name: expected a scene parameter"
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/run_vinci.cmake)
set_tests_properties(cli_mpi_design_bad_spec PROPERTIES LABELS fast TIMEOUT 120 RUN_SERIAL ON)

# Other commands do not share work: N copies would write the same files, so they refuse.
add_test(NAME cli_mpi_simulate_refused
         COMMAND ${CMAKE_COMMAND} -E env ${VINCI_MPI_ENV}
                 ${CMAKE_COMMAND} -DVINCI=${VINCI_MPIRUN} -DEXPECT_EXIT=1
                 "-DARGS=-np%%2%%--oversubscribe%%$<TARGET_FILE:vinci>%%simulate%%${VINCI_CLI_DATA}/disc_drop.yaml%%--out%%${VINCI_CLI_OUT}/mpi_simulate.csv"
                 "-DSTDERR_MATCHES=mpirun: 'vinci simulate' runs in one process"
                 -DCSV=${VINCI_CLI_OUT}/mpi_simulate.csv -DCSV_ABSENT=ON
                 -P ${CMAKE_CURRENT_SOURCE_DIR}/run_vinci.cmake)
set_tests_properties(cli_mpi_simulate_refused PROPERTIES LABELS fast TIMEOUT 120 RUN_SERIAL ON)

# `vinci design` / `vinci field` under mpirun give exactly the single-process results. Invoked by
# tests/cli/CMakeLists.txt as `cmake -D... -P mpi_compare.cmake`; list-valued variables use "%%"
# as separator. Any failed check is a FATAL_ERROR (the test fails).
#
#   VINCI    path of the executable
#   MPIRUN   path of Open MPI's mpirun
#   MODE     design (compares DIR/history.csv without its time_s column, DIR/result.json
#            without time_s and mpi, DIR/best.yaml) or field (compares the CSV byte for byte)
#   ARGS     the command's arguments, without --threads and --out
#   RUNS     RANKS:THREADS of each run; the first is the reference, e.g. "1:1%%1:2%%2:1"
#   OUT      a folder for the runs' outputs
#
# A run with more than one rank must show that it really ran on that many ranks and that every
# rank did some of the work: result.json's "mpi": {"ranks": N, "samples_per_rank": [...]}
# (design) or the summary line "mpi ranks   N (points per rank: ...)" (field). A vinci whose MPI
# calls bound to the dummy MPI of sequential MUMPS (linked by Ipopt) would see one rank each.
cmake_minimum_required(VERSION 3.22)

foreach(var ARGS RUNS)
  string(REPLACE "%%" ";" ${var} "${${var}}")
endforeach()
foreach(var VINCI MPIRUN MODE RUNS OUT)
  if(NOT DEFINED ${var})
    message(FATAL_ERROR "mpi_compare.cmake: ${var} is required")
  endif()
endforeach()

# The run's outputs with what may differ (wall times, where the work ran) taken out.
function(normalized dir out_var)
  if(MODE STREQUAL "field")
    file(READ "${dir}/field.csv" text)
  else()
    file(STRINGS "${dir}/history.csv" rows)
    set(text "")
    foreach(row IN LISTS rows)
      string(REGEX REPLACE ",[^,]*$" "" row "${row}")  # time_s is the last column
      string(APPEND text "${row}\n")
    endforeach()
    file(STRINGS "${dir}/result.json" lines)
    foreach(line IN LISTS lines)
      if(NOT line MATCHES "\"(time_s|mpi)\":")
        string(APPEND text "${line}\n")
      endif()
    endforeach()
    file(READ "${dir}/best.yaml" best)
    string(APPEND text "${best}")
  endif()
  set(${out_var} "${text}" PARENT_SCOPE)
endfunction()

set(reference "")
foreach(run IN LISTS RUNS)
  string(REPLACE ":" ";" run_list "${run}")
  list(GET run_list 0 ranks)
  list(GET run_list 1 threads)
  set(dir "${OUT}/ranks${ranks}_threads${threads}")
  file(REMOVE_RECURSE "${dir}")
  file(MAKE_DIRECTORY "${dir}")
  if(MODE STREQUAL "field")
    set(out_args --out "${dir}/field.csv")
  else()
    set(out_args --out "${dir}")
  endif()
  set(cmd "${VINCI}" ${ARGS} --threads ${threads} ${out_args})
  if(ranks GREATER 1)
    set(cmd "${MPIRUN}" -np ${ranks} --oversubscribe ${cmd})
    # Under VINCI_SANITIZE: Open MPI 4.1 leaks at MPI_Finalize (allocations of its dlopened
    # components, no frame of ours), so leak checking is off for the ranks; it stays on for the
    # single-process runs of the same job.
    set(ENV{ASAN_OPTIONS} "$ENV{ASAN_OPTIONS}:detect_leaks=0")
  endif()
  execute_process(COMMAND ${cmd} RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err
                  TIMEOUT 120)
  string(REPLACE ";" " " shown "${cmd}")
  if(NOT code EQUAL 0)
    message(FATAL_ERROR "exit code ${code}\n--- command: ${shown}\n--- stdout:\n${out}\n"
                        "--- stderr:\n${err}")
  endif()
  if(ranks GREATER 1)
    if(MODE STREQUAL "field")
      set(where "${out}")
      set(pattern "mpi ranks +([0-9]+) \\(points per rank:([ 0-9]+)\\)")
    else()
      file(READ "${dir}/result.json" where)
      set(pattern "\"mpi\": {\"ranks\": ([0-9]+), \"samples_per_rank\": \\[([0-9, ]+)\\]}")
    endif()
    if(NOT where MATCHES "${pattern}")
      message(FATAL_ERROR "no MPI summary matching '${pattern}'\n--- command: ${shown}\n"
                          "--- stdout:\n${out}\n--- stderr:\n${err}")
    endif()
    set(seen ${CMAKE_MATCH_1})
    string(REGEX MATCHALL "[0-9]+" per_rank "${CMAKE_MATCH_2}")
    list(LENGTH per_rank n)
    if(NOT seen EQUAL ranks OR NOT n EQUAL ranks)
      message(FATAL_ERROR "started ${ranks} ranks, vinci saw ${seen} (work per rank: "
                          "${per_rank})\n--- command: ${shown}\n--- stdout:\n${out}")
    endif()
    foreach(items IN LISTS per_rank)
      if(items EQUAL 0)
        message(FATAL_ERROR "a rank did no work (work per rank: ${per_rank})\n"
                            "--- command: ${shown}\n--- stdout:\n${out}")
      endif()
    endforeach()
    message(STATUS "${shown}: ${seen} ranks, work per rank ${per_rank}")
  endif()
  normalized("${dir}" text)
  if(reference STREQUAL "")
    set(reference "${text}")
    set(reference_run "${run}")
    if(text STREQUAL "")
      message(FATAL_ERROR "empty output\n--- command: ${shown}")
    endif()
  elseif(NOT text STREQUAL reference)
    file(WRITE "${dir}/normalized.txt" "${text}")
    file(WRITE "${OUT}/reference_normalized.txt" "${reference}")
    message(FATAL_ERROR "run ${run} (ranks:threads) differs from run ${reference_run}: "
                        "diff ${OUT}/reference_normalized.txt ${dir}/normalized.txt")
  endif()
endforeach()

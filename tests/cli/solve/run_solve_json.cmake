# Runs `vinci solve ... --json` once and checks its JSON report. Invoked by the tests in
# tests/cli/solve/CMakeLists.txt as `cmake -D... -P run_solve_json.cmake`; list-valued variables
# use "%%" as separator. Any failed check is a FATAL_ERROR (test fails).
#
#   VINCI           path of the executable
#   ARGS            its arguments (including --json)
#   EXPECT_EXIT     required exit code
#   STDOUT_MATCHES  regular expressions that must all match stdout (the raw JSON text)
#   STDERR_MATCHES  regular expressions that must all match stderr
#   JSON_CHECKS     checks on the parsed report, each on a member path (components separated by
#                   '.', array indices 0-based, e.g. "z.2"):
#                     "path=text"    the value, as string(JSON GET) returns it, equals text
#                                    (strings verbatim, booleans ON/OFF)
#                     "path:lo:hi"   numeric, lo <= value <= hi
#
# Always checked: stdout is exactly one JSON object (and nothing else) with exactly the members
# problem, n, solver, status, iterations, residual, time_s, regularized, regularization,
# message, z, w, each of the documented type (residual may be null), and z and w are arrays of
# n numbers (or nulls).
cmake_minimum_required(VERSION 3.22)

function(fail msg)
  message(FATAL_ERROR "${msg}\n--- command: ${VINCI} ${ARGS}\n--- exit code: ${code}\n"
                      "--- stdout:\n${out}\n--- stderr:\n${err}")
endfunction()

foreach(var ARGS STDOUT_MATCHES STDERR_MATCHES JSON_CHECKS)
  string(REPLACE "%%" ";" ${var} "${${var}}")
endforeach()
if(NOT DEFINED VINCI OR NOT DEFINED EXPECT_EXIT)
  message(FATAL_ERROR "run_solve_json.cmake: VINCI and EXPECT_EXIT are required")
endif()

execute_process(COMMAND "${VINCI}" ${ARGS}
  RESULT_VARIABLE code OUTPUT_VARIABLE out ERROR_VARIABLE err TIMEOUT 60)

if(NOT "${code}" STREQUAL "${EXPECT_EXIT}")
  fail("expected exit code ${EXPECT_EXIT}")
endif()
foreach(re IN LISTS STDOUT_MATCHES)
  if(NOT out MATCHES "${re}")
    fail("stdout does not match '${re}'")
  endif()
endforeach()
foreach(re IN LISTS STDERR_MATCHES)
  if(NOT err MATCHES "${re}")
    fail("stderr does not match '${re}'")
  endif()
endforeach()

# One object and nothing else (CMake's parser ignores trailing text, so check the shape too).
if(NOT out MATCHES "^{\n.*\n}\n$")
  fail("stdout is not a single JSON object on its own")
endif()
string(JSON num_members ERROR_VARIABLE json_error LENGTH "${out}")
if(json_error)
  fail("stdout is not valid JSON: ${json_error}")
endif()

set(schema problem STRING n NUMBER solver STRING status STRING iterations NUMBER
           residual NUMBER|NULL time_s NUMBER regularized BOOLEAN regularization NUMBER
           message STRING z ARRAY w ARRAY)
list(LENGTH schema schema_length)
math(EXPR expected_members "${schema_length} / 2")
if(NOT num_members EQUAL expected_members)
  fail("the report has ${num_members} members, expected ${expected_members}")
endif()
while(schema)
  list(POP_FRONT schema member types)
  string(JSON type ERROR_VARIABLE json_error TYPE "${out}" ${member})
  if(json_error)
    fail("the report has no member '${member}'")
  endif()
  string(REPLACE "|" ";" types "${types}")
  if(NOT type IN_LIST types)
    fail("member '${member}' is ${type}, expected ${types}")
  endif()
endwhile()
string(JSON n GET "${out}" n)
foreach(array z w)
  string(JSON length LENGTH "${out}" ${array})
  if(NOT length EQUAL n)
    fail("'${array}' has ${length} entries, n = ${n}")
  endif()
  math(EXPR last "${n} - 1")
  foreach(i RANGE ${last})
    string(JSON type TYPE "${out}" ${array} ${i})
    if(NOT type MATCHES "^(NUMBER|NULL)$")
      fail("${array}[${i}] is ${type}, expected a number")
    endif()
  endforeach()
endforeach()

foreach(check IN LISTS JSON_CHECKS)
  if(check MATCHES "^([^:=]+):([^:]+):([^:]+)$")
    set(path "${CMAKE_MATCH_1}")
    set(lo "${CMAKE_MATCH_2}")
    set(hi "${CMAKE_MATCH_3}")
    set(numeric TRUE)
  elseif(check MATCHES "^([^:=]+)=(.*)$")
    set(path "${CMAKE_MATCH_1}")
    set(expected "${CMAKE_MATCH_2}")
    set(numeric FALSE)
  else()
    message(FATAL_ERROR "run_solve_json.cmake: bad JSON check '${check}'")
  endif()
  string(REPLACE "." ";" components "${path}")
  string(JSON value ERROR_VARIABLE json_error GET "${out}" ${components})
  if(json_error)
    fail("the report has no '${path}': ${json_error}")
  endif()
  if(numeric)
    string(JSON type TYPE "${out}" ${components})
    if(NOT type STREQUAL "NUMBER" OR NOT (value GREATER_EQUAL lo AND value LESS_EQUAL hi))
      fail("${path} = ${value} (${type}), expected a number in [${lo}, ${hi}]")
    endif()
  elseif(NOT value STREQUAL expected)
    fail("${path} = '${value}', expected '${expected}'")
  endif()
endforeach()

# Installs this build into a fresh prefix, builds tests/install/consumer (a shared library on the
# public API, a program that calls it, and the first C++ session of README.md) against it and
# runs them,
# then runs the installed `servokit` on an installed model (issue #7: cmake --install and
# find_package), and imports the installed Python module (issue #17). Called by CTest:
#   cmake -DBINARY_DIR=... -DSOURCE_DIR=... -DWORK_DIR=... -DCXX_COMPILER=... -DPYTHON=...
#   -DPYTHON_DIR=... -P consumer_test.cmake
function(run)
  execute_process(COMMAND ${ARGN} RESULT_VARIABLE status OUTPUT_VARIABLE out ERROR_VARIABLE err)
  if(NOT status EQUAL 0)
    message(FATAL_ERROR "failed (${status}): ${ARGN}\n${out}\n${err}")
  endif()
  message(STATUS "${ARGN}\n${out}")
  set(output "${out}" PARENT_SCOPE)
endfunction()

file(REMOVE_RECURSE ${WORK_DIR})
set(prefix ${WORK_DIR}/prefix)
run(${CMAKE_COMMAND} --install ${BINARY_DIR} --prefix ${prefix})
foreach(path bin/servokit include/servokit/servokit.h include/servokit/base/errors.h
        share/servokit/models/mass_on_car.yaml lib/cmake/servokit/servokitConfig.cmake)
  if(NOT EXISTS ${prefix}/${path})
    message(FATAL_ERROR "not installed: ${path}")
  endif()
endforeach()
# Only the public API (with the errors, the process group and the vocabulary of classes it
# exports from base/): no internal
# header (GiNaC, SUNDIALS, CLI11, json behind them) is installed.
file(GLOB_RECURSE installed_headers RELATIVE ${prefix}/include ${prefix}/include/*)
set(public_headers servokit/base/errors.h servokit/base/process_group.h
    servokit/base/vocabulary.h servokit/servokit.h)
if(NOT installed_headers STREQUAL "${public_headers}")
  message(FATAL_ERROR "installed headers beyond the public API: ${installed_headers}")
endif()

# The consumer sees only the installed tree: its own source folder and the prefix.
run(${CMAKE_COMMAND} -S ${SOURCE_DIR}/tests/install/consumer -B ${WORK_DIR}/build
    -DCMAKE_PREFIX_PATH=${prefix} -DCMAKE_CXX_COMPILER=${CXX_COMPILER} -DCMAKE_BUILD_TYPE=Release)
run(${CMAKE_COMMAND} --build ${WORK_DIR}/build)
run(${WORK_DIR}/build/consumer)
# The first C++ session of README.md and docs/cpp.md prints what they show: the block after
# the comment <!-- output: tests/install/consumer/first_session.cpp --> (issue #30).
run(${WORK_DIR}/build/first_session)
set(marker "<!-- output: tests/install/consumer/first_session.cpp -->\n```text\n")
string(LENGTH "${marker}" marker_length)
foreach(page README.md docs/cpp.md)
  file(READ ${SOURCE_DIR}/${page} text)
  string(FIND "${text}" "${marker}" start)
  if(start EQUAL -1)
    message(FATAL_ERROR "${page} shows no output of first_session.cpp (${marker})")
  endif()
  math(EXPR start "${start} + ${marker_length}")
  string(SUBSTRING "${text}" ${start} -1 shown)
  string(FIND "${shown}" "```" end)
  string(SUBSTRING "${shown}" 0 ${end} shown)
  if(NOT output STREQUAL shown)
    message(FATAL_ERROR "first_session printed\n${output}\nbut ${page} shows\n${shown}")
  endif()
endforeach()

run(${prefix}/bin/servokit --version)
run(${prefix}/bin/servokit analyze ${prefix}/share/servokit/models/mass_on_car.yaml --format json)
if(NOT output MATCHES "\"realization\"")
  message(FATAL_ERROR "the installed servokit printed no classification")
endif()
# The Python module, where `cmake --install` put it (a path relative to the prefix; an absolute
# SERVOKIT_PYTHON_INSTALL_DIR lies outside the prefix and is not checked here). A newline, not
# ";", between the statements: run() passes its arguments on as a list.
if(NOT IS_ABSOLUTE "${PYTHON_DIR}")
  run(${CMAKE_COMMAND} -E env PYTHONPATH=${prefix}/${PYTHON_DIR} ${PYTHON} -c
      "import servokit\nprint(servokit.load('${prefix}/share/servokit/models/mass_on_car.yaml').analyze().realization)")
  if(NOT output MATCHES "non-ideal-orthogonal")
    message(FATAL_ERROR "the installed Python module did not classify the model: ${output}")
  endif()
endif()
file(REMOVE_RECURSE ${WORK_DIR})

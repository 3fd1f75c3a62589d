include(GoogleTest)
# Warnings for the project's own code only (dependencies are included as SYSTEM).
function(dentar_warnings target)
  target_compile_features(${target} PRIVATE cxx_std_20)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic)
  if(DENTAR_WERROR)
    target_compile_options(${target} PRIVATE -Werror)
  endif()
  if(DENTAR_TSAN)
    target_compile_options(${target} PRIVATE -fsanitize=thread -g)
    target_link_options(${target} PRIVATE -fsanitize=thread)
  endif()
endfunction()

# dentar_module(<name> SOURCES ... DEPS ...): one library per module, public
# headers in <module>/include/dentar/<module>/.
function(dentar_module name)
  cmake_parse_arguments(M "" "" "SOURCES;PUBLIC_DEPS;PRIVATE_DEPS" ${ARGN})
  add_library(dentar_${name} STATIC ${M_SOURCES})
  add_library(dentar::${name} ALIAS dentar_${name})
  target_include_directories(dentar_${name}
    PUBLIC ${CMAKE_CURRENT_SOURCE_DIR}/include
    PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/src)
  target_link_libraries(dentar_${name} PUBLIC ${M_PUBLIC_DEPS} PRIVATE ${M_PRIVATE_DEPS})
  dentar_warnings(dentar_${name})
endfunction()

# dentar_test(<name> SOURCES ... DEPS ... [LABELS ...]): one GoogleTest binary,
# registered with ctest per test case. Working directory is the source root so
# tests find ../shared/data the same way the README does.
# COST: ctest starts higher-cost tests first (a long test then overlaps the
# others instead of running alone at the end).
# SERIAL: the test runs alone (ctest RUN_SERIAL), for tests that measure
# real-time behaviour (frames a live run processes) and fail when another
# heavy test shares the two cores.
# ONE_PROCESS <ctest name>: the binary's tests run as one ctest in one process, for
# binaries whose tests share an expensive fixture in a static cache (generated footage,
# a generated cohort): per-test processes would each build it again. Filter inside it with
# --gtest_filter.
# QUICK_FILTER <gtest filter> (with ONE_PROCESS): the whole binary becomes a `long` test
# (ctest -L long) and <ctest name>.Quick runs only the filter, with QUICK_ENV (a list of
# NAME=VALUE) in its environment: a seeded subset that keeps CI within its time.
function(dentar_test name)
  cmake_parse_arguments(T "SERIAL" "TIMEOUT;COST;ONE_PROCESS;QUICK_FILTER" "SOURCES;DEPS;LABELS;QUICK_ENV" ${ARGN})
  add_executable(${name} ${T_SOURCES})
  target_link_libraries(${name} PRIVATE ${T_DEPS} dentar_testutil GTest::gtest GTest::gtest_main)
  dentar_warnings(${name})
  if(NOT T_TIMEOUT)
    set(T_TIMEOUT 600)
  endif()
  set(_serial "")
  if(T_SERIAL)
    set(_serial RUN_SERIAL TRUE)
  endif()
  if(T_COST)
    list(APPEND _serial COST ${T_COST})
  endif()
  if(T_ONE_PROCESS)
    add_test(NAME ${T_ONE_PROCESS} COMMAND ${name} WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
    if(T_QUICK_FILTER)
      set(_long_labels ${T_LABELS} long)
      set_tests_properties(${T_ONE_PROCESS} PROPERTIES LABELS "${_long_labels}" TIMEOUT ${T_TIMEOUT} ${_serial})
      add_test(NAME ${T_ONE_PROCESS}.Quick COMMAND ${name} --gtest_filter=${T_QUICK_FILTER}
               WORKING_DIRECTORY ${PROJECT_SOURCE_DIR})
      set_tests_properties(${T_ONE_PROCESS}.Quick PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT}
                           ENVIRONMENT "${T_QUICK_ENV}" ${_serial})
    else()
      set_tests_properties(${T_ONE_PROCESS} PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT} ${_serial})
    endif()
    return()
  endif()
  gtest_discover_tests(${name}
    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
    PROPERTIES LABELS "${T_LABELS}" TIMEOUT ${T_TIMEOUT} ${_serial}
    DISCOVERY_TIMEOUT 60)
endfunction()

function(dentar_bench name)
  cmake_parse_arguments(B "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${B_SOURCES})
  target_link_libraries(${name} PRIVATE ${B_DEPS} benchmark::benchmark)
  dentar_warnings(${name})
endfunction()

# A module's fuzz targets: every fuzz_*.cpp in the calling directory (each defines
# LLVMFuzzerTestOneInput).
#  - With DENTAR_FUZZ (clang): a libFuzzer binary <PREFIX><name> (ASan + UBSan).
#  - With tests: <PREFIX><name>_replay = the target + REPLAY_MAIN (a replay driver without
#    libFuzzer), run as a ctest labelled "fuzz;<LABEL>" on corpus/<name> plus MUTATIONS
#    deterministic mutations (a variable <name>_MUTATIONS overrides the count per target),
#    with <name>.dict when it exists, and a per-input time limit when MAX_INPUT_SECONDS is
#    given (text replay driver: a hang fails the test instead of stalling the suite).
function(dentar_fuzz_targets)
  cmake_parse_arguments(F "" "PREFIX;LABEL;REPLAY_MAIN;MUTATIONS;MAX_INPUT_SECONDS" "DEPS" ${ARGN})
  if(NOT F_MUTATIONS)
    set(F_MUTATIONS 20000)
  endif()
  file(GLOB targets CONFIGURE_DEPENDS ${CMAKE_CURRENT_SOURCE_DIR}/fuzz_*.cpp)
  foreach(f ${targets})
    get_filename_component(n ${f} NAME_WE)
    set(t ${F_PREFIX}${n})
    if(DENTAR_FUZZ)
      add_executable(${t} ${f})
      target_link_libraries(${t} PRIVATE ${F_DEPS})
      target_compile_options(${t} PRIVATE -fsanitize=fuzzer,address,undefined -g)
      target_link_options(${t} PRIVATE -fsanitize=fuzzer,address,undefined)
    endif()
    if(DENTAR_BUILD_TESTS)
      add_executable(${t}_replay ${f} ${F_REPLAY_MAIN})
      target_link_libraries(${t}_replay PRIVATE ${F_DEPS})
      dentar_warnings(${t}_replay)
      target_include_directories(${t}_replay PRIVATE ${PROJECT_SOURCE_DIR}/tests/fuzzutil)
      set(m ${F_MUTATIONS})
      if(DEFINED ${n}_MUTATIONS)
        set(m ${${n}_MUTATIONS})
      endif()
      set(args ${CMAKE_CURRENT_SOURCE_DIR}/corpus/${n} --mutations ${m})
      if(EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${n}.dict)
        list(APPEND args --dict ${CMAKE_CURRENT_SOURCE_DIR}/${n}.dict)
      endif()
      if(F_MAX_INPUT_SECONDS)
        list(APPEND args --max-input-seconds ${F_MAX_INPUT_SECONDS})
      endif()
      add_test(NAME ${t}_replay COMMAND ${t}_replay ${args})
      set_tests_properties(${t}_replay PROPERTIES LABELS "fuzz;${F_LABEL}" TIMEOUT 600)
    endif()
  endforeach()
endfunction()

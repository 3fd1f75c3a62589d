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
# SERIAL: the test runs alone (ctest RUN_SERIAL), for tests that measure
# real-time behaviour (frames a live run processes) and fail when another
# heavy test shares the two cores.
function(dentar_test name)
  cmake_parse_arguments(T "SERIAL" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
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

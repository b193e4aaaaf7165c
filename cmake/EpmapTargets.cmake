# Helpers that give every target of ours the same strictness.

# Warnings are errors on our code; generated code gets its own targets without this.
function(epmap_strict target)
  target_compile_options(${target} PRIVATE -Wall -Wextra -Wpedantic -Werror
                         -Wno-error=deprecated-declarations)
endfunction()

# epmap_library(NAME SOURCES ... DEPS ...): a static library of ours, include root = repo root.
function(epmap_library name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_library(${name} STATIC ${ARG_SOURCES})
  target_include_directories(${name} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PUBLIC ${ARG_DEPS})
  set_target_properties(${name} PROPERTIES POSITION_INDEPENDENT_CODE ON)
  epmap_strict(${name})
endfunction()

# epmap_executable(NAME SOURCES ... DEPS ...): a binary of ours, lands in build/bin.
function(epmap_executable name)
  cmake_parse_arguments(ARG "" "" "SOURCES;DEPS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS})
  epmap_strict(${name})
endfunction()

# epmap_test(NAME SOURCES ... DEPS ... LABELS ... [TIMEOUT s]): a GoogleTest binary under CTest.
function(epmap_test name)
  cmake_parse_arguments(ARG "" "TIMEOUT" "SOURCES;DEPS;LABELS" ${ARGN})
  add_executable(${name} ${ARG_SOURCES})
  target_include_directories(${name} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${name} PRIVATE ${ARG_DEPS} GTest::gtest GTest::gtest_main)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  # The same places as CTest's environment below, for a test binary run by hand.
  target_compile_definitions(${name} PRIVATE
    EPMAP_DEFAULT_BIN_DIR="${CMAKE_BINARY_DIR}/bin"
    EPMAP_DEFAULT_SOURCE_DIR="${PROJECT_SOURCE_DIR}"
    EPMAP_DEFAULT_SHARED_DIR="${PROJECT_SOURCE_DIR}/../shared")
  epmap_strict(${name})
  if(NOT ARG_TIMEOUT)
    set(ARG_TIMEOUT 120)
  endif()
  add_test(NAME ${name} COMMAND ${name})
  set_tests_properties(${name} PROPERTIES LABELS "${ARG_LABELS}" TIMEOUT ${ARG_TIMEOUT}
    ENVIRONMENT "EPMAP_BIN_DIR=${CMAKE_BINARY_DIR}/bin;EPMAP_SOURCE_DIR=${PROJECT_SOURCE_DIR};EPMAP_SHARED_DIR=${PROJECT_SOURCE_DIR}/../shared;SKIP_DEFAULT_XML_FILE=1")
endfunction()

# Adds every immediate subfolder of the current folder that has a CMakeLists.txt, so that a new
# capability folder is picked up without editing its parent.
function(epmap_add_subfolders)
  file(GLOB children LIST_DIRECTORIES true RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}
       ${CMAKE_CURRENT_SOURCE_DIR}/*)
  list(SORT children)
  foreach(child ${children})
    if(IS_DIRECTORY ${CMAKE_CURRENT_SOURCE_DIR}/${child}
       AND EXISTS ${CMAKE_CURRENT_SOURCE_DIR}/${child}/CMakeLists.txt)
      add_subdirectory(${child})
    endif()
  endforeach()
endfunction()

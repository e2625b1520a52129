# One library per folder, linking only downward (same shape as COLMAP_ADD_LIBRARY). Sources are
# listed explicitly (no file(GLOB)). DEPS are PUBLIC: what the folder's headers expose to their
# users; PRIVATE_DEPS only what its .cpp files use (Ceres, OpenCV, SQLite, libmodbus, …).
#   km_add_library(NAME km_geometry SRCS a.cpp b.cpp DEPS km_core Eigen3::Eigen
#                  [PRIVATE_DEPS Ceres::ceres])
#   km_add_test(NAME geometry_test SRCS x_test.cpp DEPS km_geometry [LABELS unit] [COST seconds])
#   km_add_benchmark(NAME dbb_bench SRCS dbb_bench.cpp DEPS km_dbb)

# Unity batches (KINEMETRIC_UNITY, on by default): the .cpp files of a target are compiled
# KM_UNITY_BATCH at a time, as one translation unit that includes them. Most of a test's compile
# time is spent instantiating the same gtest, Eigen and nlohmann templates; a batch does that
# once. The batch files include their sources by paths relative to the repository root (unlike
# CMake's own UNITY_BUILD, which writes absolute paths), so ccache finds them again from another
# checkout. A file's anonymous-namespace names are therefore seen by the files after it in its
# batch: give helpers distinct names, or share them through a header.
set(KM_UNITY_BATCH 8 CACHE STRING "Source files per unity batch (KINEMETRIC_UNITY)")

# Replaces the .cpp files of `srcs` (relative to the current source folder or absolute, inside
# the repository) by unity batch files of `target`; other sources pass through.
function(km_unity_sources target srcs out_var)
  if(NOT KINEMETRIC_UNITY)
    set(${out_var} ${srcs} PARENT_SCOPE)
    return()
  endif()
  set(result "")
  set(batch "")
  set(count 0)
  set(index 0)
  set(batch_dir "")
  foreach(src ${srcs})
    get_filename_component(abs "${src}" ABSOLUTE BASE_DIR "${CMAKE_CURRENT_SOURCE_DIR}")
    file(RELATIVE_PATH rel "${PROJECT_SOURCE_DIR}" "${abs}")
    if(NOT abs MATCHES "\\.cpp$" OR rel MATCHES "^\\.\\.")
      list(APPEND result "${src}")
      continue()
    endif()
    # A batch holds files of one folder: rooms (e.g. the two storage back-ends) stay apart.
    get_filename_component(dir "${rel}" DIRECTORY)
    if(count GREATER 0 AND NOT dir STREQUAL batch_dir)
      km_flush_unity_batch()
    endif()
    set(batch_dir "${dir}")
    string(APPEND batch "#include \"${rel}\"\n")
    math(EXPR count "${count} + 1")
    if(count EQUAL KM_UNITY_BATCH)
      km_flush_unity_batch()
    endif()
  endforeach()
  if(count GREATER 0)
    km_flush_unity_batch()
  endif()
  set(${out_var} ${result} PARENT_SCOPE)
endfunction()

# Writes the batch collected in km_unity_sources (its variables target, index, batch) to
# <build folder>/unity/<target>_<index>.cpp, adds it to `result` and starts the next batch. The
# file is written only when its content changes, so an unchanged batch is not rebuilt.
macro(km_flush_unity_batch)
  set(_km_unity_file "${CMAKE_CURRENT_BINARY_DIR}/unity/${target}_${index}.cpp")
  file(CONFIGURE OUTPUT "${_km_unity_file}"
       CONTENT "// Unity batch of ${target} (cmake/KinemetricHelpers.cmake).\n${batch}")
  list(APPEND result "${_km_unity_file}")
  set(batch "")
  set(count 0)
  math(EXPR index "${index} + 1")
endmacro()

# Marks a target as product code: the sanitizer build instruments it (KM_PRODUCT_COMPILE_OPTIONS,
# top-level CMakeLists.txt); test programs' own files are left as the build type compiles them.
function(km_product_target target)
  if(KM_PRODUCT_COMPILE_OPTIONS)
    target_compile_options(${target} PRIVATE ${KM_PRODUCT_COMPILE_OPTIONS})
  endif()
endfunction()

function(km_add_library)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS;PRIVATE_DEPS" ${ARGN})
  km_unity_sources(${ARG_NAME} "${ARG_SRCS}" srcs)
  add_library(${ARG_NAME} STATIC ${srcs})
  km_product_target(${ARG_NAME})
  target_include_directories(${ARG_NAME} PUBLIC ${PROJECT_SOURCE_DIR})
  target_link_libraries(${ARG_NAME} PUBLIC ${ARG_DEPS})
  if(ARG_PRIVATE_DEPS)
    target_link_libraries(${ARG_NAME} PRIVATE ${ARG_PRIVATE_DEPS})
  endif()
endfunction()

function(km_add_test)
  cmake_parse_arguments(ARG "" "NAME;COST" "SRCS;DEPS;LABELS" ${ARGN})
  km_unity_sources(${ARG_NAME} "${ARG_SRCS}" srcs)
  add_executable(${ARG_NAME} ${srcs})
  # KM_TEST_UNOPTIMISED (set by tests/CMakeLists.txt for the folders whose tests drive the
  # product and compute little themselves): the test's own files are compiled at -O0.
  if(KM_TEST_UNOPTIMISED)
    target_compile_options(${ARG_NAME} PRIVATE -O0)
  endif()
  target_include_directories(${ARG_NAME} PRIVATE ${PROJECT_SOURCE_DIR})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_DEPS} GTest::gtest_main)
  set_target_properties(${ARG_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/tests)
  if(NOT ARG_LABELS)
    set(ARG_LABELS unit)
  endif()
  # COST: the seconds a test of the program takes, for CTest to start the long ones first in a
  # run with no cost data of its own (a fresh build directory); tests/CMakeLists.txt.
  set(cost_property "")
  if(ARG_COST)
    set(cost_property COST ${ARG_COST})
  endif()
  gtest_discover_tests(${ARG_NAME} PROPERTIES LABELS "${ARG_LABELS}" ${cost_property}
                       WORKING_DIRECTORY ${PROJECT_SOURCE_DIR} DISCOVERY_TIMEOUT 60)
endfunction()

function(km_add_benchmark)
  cmake_parse_arguments(ARG "" "NAME" "SRCS;DEPS" ${ARGN})
  if(NOT KINEMETRIC_BENCHMARKS)
    return()
  endif()
  add_executable(${ARG_NAME} ${ARG_SRCS})
  target_link_libraries(${ARG_NAME} PRIVATE ${ARG_DEPS} benchmark::benchmark)
  set_target_properties(${ARG_NAME} PROPERTIES RUNTIME_OUTPUT_DIRECTORY ${CMAKE_BINARY_DIR}/bench)
endfunction()

# SPDX-License-Identifier: Apache-2.0
# Double-precision reference (host/lib/tables/ef_ref.c, ef_ref_opt.c).
find_package(Threads REQUIRED)
add_executable(test_ref ${CMAKE_CURRENT_SOURCE_DIR}/table/test_ref.c)
target_include_directories(test_ref PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_ref PRIVATE ef_host Threads::Threads m)
add_test(NAME ref COMMAND test_ref)
set_tests_properties(ref PROPERTIES TIMEOUT 120)

# Timing printout (not a test): build bench_ref in a build without sanitizers.
add_executable(bench_ref ${CMAKE_CURRENT_SOURCE_DIR}/bench/bench_ref.c)
target_link_libraries(bench_ref PRIVATE ef_host m)

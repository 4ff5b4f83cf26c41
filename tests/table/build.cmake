# SPDX-License-Identifier: Apache-2.0
# Resumable, sharded table builds: driver, journal, shard files, merge (host/lib/tables/ef_build.c,
# host/lib/tables/ef_shard.c; docs/table-build.md). Test names start with "build".
add_executable(test_build ${CMAKE_CURRENT_SOURCE_DIR}/table/test_build.c)
target_include_directories(test_build PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_build PRIVATE ef_host m)
add_test(NAME build_driver COMMAND test_build)
set_tests_properties(build_driver PROPERTIES ENVIRONMENT "TMPDIR=${CMAKE_CURRENT_BINARY_DIR}"
                     TIMEOUT 300)

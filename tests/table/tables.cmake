# SPDX-License-Identifier: Apache-2.0
# The shipped default tables and the command line, end to end.
if(TARGET ef_tables_default)
  add_executable(test_tables ${CMAKE_CURRENT_SOURCE_DIR}/table/test_tables.c)
  target_link_libraries(test_tables PRIVATE ef_host ef_tables_default)
  add_test(NAME tables_default COMMAND test_tables ${PROJECT_SOURCE_DIR})
  add_test(NAME cli COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/table/test_cli.sh $<TARGET_FILE:evenfeed> ${PROJECT_SOURCE_DIR})
endif()

# Benchmark (prints figures, asserts nothing): cost of the planar G1 table on 3-D data.
if(TARGET ef_tables_default)
  add_executable(bench_twist bench/bench_twist.c)
  target_link_libraries(bench_twist PRIVATE ef_host ef_tables_default)
endif()

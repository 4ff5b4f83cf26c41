# SPDX-License-Identifier: Apache-2.0
# ctest tests of the costs image (included by tests/m4/tests.cmake): m4_costs_O2 / _Os run it
# under QEMU and check that it ran, printed every cost line, and that every entry point's
# measured stack high-water is within its static bound (tests/m4/costs_check.sh). The issue's
# targets are figures of ./dev bench (tests/bench/run_all.sh), not asserted here.
foreach(opt O2 Os)
  add_test(NAME m4_costs_${opt}
           COMMAND sh ${CMAKE_CURRENT_LIST_DIR}/costs_check.sh ${EF_M4_DIR_${opt}})
  set_tests_properties(m4_costs_${opt} PROPERTIES
    ENVIRONMENT "EF_M4_REQUIRED=${EF_M4_REQUIRED}" SKIP_RETURN_CODE 77 TIMEOUT 600)
endforeach()

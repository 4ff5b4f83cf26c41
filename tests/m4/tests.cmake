# SPDX-License-Identifier: Apache-2.0
# ctest tests of the images of tests/m4 (included by tests/m4/m4.cmake).

# Golden cases: the M4 image under QEMU against the host build of the same source, line by
# line (tests/m4/golden_compare.sh); at -O2 and -Os.
if(TARGET golden_host)
  foreach(opt O2 Os)
    add_test(NAME m4_golden_${opt}
             COMMAND sh ${CMAKE_CURRENT_LIST_DIR}/golden_compare.sh --limit 120
                     ${EF_M4_DIR_${opt}}/m4_golden.elf $<TARGET_FILE:golden_host>
                     ${CMAKE_CURRENT_BINARY_DIR}/m4_golden_${opt})
    set_tests_properties(m4_golden_${opt} PROPERTIES
      ENVIRONMENT "EF_M4_REQUIRED=${EF_M4_REQUIRED}" SKIP_RETURN_CODE 77 TIMEOUT 300
      PASS_REGULAR_EXPRESSION "m4_golden: [0-9]+ cases agree")
  endforeach()
endif()

# Costs and stack (tests/m4/costs_tests.cmake).
include(${CMAKE_CURRENT_LIST_DIR}/costs_tests.cmake)

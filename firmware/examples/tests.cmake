# SPDX-License-Identifier: Apache-2.0
# ctest tests of the integration example (firmware/examples/README.md; included by
# tests/m4/m4.cmake when present): the image under QEMU at icount shift 3, the shift its
# board support is compiled for (firmware/examples/images.cmake), at -O2 and -Os.
if(TARGET golden_gen)
  foreach(opt O2 Os)
    add_test(NAME m4_example_${opt}
             COMMAND sh ${PROJECT_SOURCE_DIR}/tests/m4/qemu_run.sh --limit 120 --shift 3
                     ${EF_M4_DIR_${opt}}/m4_example.elf)
    set_tests_properties(m4_example_${opt} PROPERTIES
      ENVIRONMENT "EF_M4_REQUIRED=${EF_M4_REQUIRED}" SKIP_RETURN_CODE 77 TIMEOUT 180
      PASS_REGULAR_EXPRESSION "m4_example: ok")
  endforeach()
endif()

# SPDX-License-Identifier: Apache-2.0
# G-code reader: unit tests, the sample program, the CLI, and the fuzz corpus replay
# (docs/gcode.md). Test names start with "gcode" (ctest -R gcode).
set(EF_GCODE_DIR ${CMAKE_CURRENT_SOURCE_DIR})

add_executable(test_gcode ${CMAKE_CURRENT_SOURCE_DIR}/program/test_gcode.c)
target_include_directories(test_gcode PRIVATE ${EF_GCODE_DIR})
target_compile_definitions(test_gcode PRIVATE EF_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
target_link_libraries(test_gcode PRIVATE ef_host m)
add_test(NAME gcode_unit COMMAND test_gcode)

# The sample part program must read cleanly through the CLI, in both output forms.
add_test(NAME gcode_cli_sample COMMAND evenfeed gcode ${PROJECT_SOURCE_DIR}/samples/bracket.ngc)
add_test(NAME gcode_cli_sample_json
         COMMAND evenfeed gcode ${PROJECT_SOURCE_DIR}/samples/bracket.ngc --json)
set_tests_properties(gcode_cli_sample PROPERTIES PASS_REGULAR_EXPRESSION "61:6 end +M30")
set_tests_properties(gcode_cli_sample_json PROPERTIES
                     PASS_REGULAR_EXPRESSION "\"kind\": \"end\", \"line\": 61, .*\"text\": \"M30\"")
# The machine's files: G54 X100 Y50 Z-80 from the parameter file moves the first rapid; a bad
# line is refused with file:line before anything is read.
set(EF_MACHINE_DIR ${PROJECT_SOURCE_DIR}/tests/data/machine)
add_test(NAME gcode_cli_machine
         COMMAND evenfeed gcode ${PROJECT_SOURCE_DIR}/samples/bracket.ngc
                 --params ${EF_MACHINE_DIR}/mill.var --tool-table ${EF_MACHINE_DIR}/mill.tbl)
set_tests_properties(gcode_cli_machine PROPERTIES PASS_REGULAR_EXPRESSION
                     "18:5 rapid +0.0000 0.0000 -75.0000 -> 115.0000 60.0000 -75.0000")
add_test(NAME gcode_cli_machine_bad
         COMMAND sh -c "$<TARGET_FILE:evenfeed> gcode \"$1\" --params \"$2\"; echo \"exit $?\"" sh
                 ${PROJECT_SOURCE_DIR}/samples/bracket.ngc ${EF_MACHINE_DIR}/bad.var)
set_tests_properties(gcode_cli_machine_bad PROPERTIES PASS_REGULAR_EXPRESSION
                     "bad.var:2: value 'fifty' of #5222 not a number.*exit 1")
add_test(NAME smooth_cli_machine
         COMMAND evenfeed smooth ${PROJECT_SOURCE_DIR}/samples/bracket.ngc
                 --params ${EF_MACHINE_DIR}/mill.var --tool-table ${EF_MACHINE_DIR}/mill.tbl)
set_tests_properties(smooth_cli_machine PROPERTIES PASS_REGULAR_EXPRESSION
                     "end position +175.0000 90.0000 -55.0000 mm")
# A B C U V W on the moves that carry them (text after '|', JSON abcuvw_start/_end).
add_test(NAME gcode_cli_axes COMMAND evenfeed gcode ${PROJECT_SOURCE_DIR}/tests/data/axes_moves.ngc)
set_tests_properties(gcode_cli_axes PROPERTIES PASS_REGULAR_EXPRESSION
                     "F600 \\| A 0.0000 -> 90.0000\n.*F600 \\| A 90.0000\n.*rapid .* \\| A 90.0000 B 0.0000 -> -45.0000 U 0.0000 -> 3.0000\n")
add_test(NAME gcode_cli_axes_json
         COMMAND evenfeed gcode ${PROJECT_SOURCE_DIR}/tests/data/axes_moves.ngc --json)
set_tests_properties(gcode_cli_axes_json PROPERTIES PASS_REGULAR_EXPRESSION
                     "\"abcuvw_start\": \\[90, 0, 0, 0, 0, 0\\], \"abcuvw_end\": \\[90, -45, 0, 3, 0, 0\\]")
add_test(NAME gcode_cli_missing COMMAND evenfeed gcode ${CMAKE_CURRENT_BINARY_DIR}/no-such.ngc)
set_tests_properties(gcode_cli_missing PROPERTIES WILL_FAIL TRUE)
# A bad program: the message names file, line and column; exit status 11 (EF_ERR_GCODE).
add_test(NAME gcode_cli_error
         COMMAND sh -c "$<TARGET_FILE:evenfeed> gcode \"$1\"; echo \"exit $?\"" sh
                 ${EF_GCODE_DIR}/fuzz/corpus_gcode/bad-radius.ngc)
set_tests_properties(gcode_cli_error PROPERTIES
                     PASS_REGULAR_EXPRESSION "bad-radius.ngc:2:1: G2 arc radius mismatch: start 5.0000 end 4.0000 .differ by 1 mm.*exit 11")

# Seed corpus replay through the fuzz entry point, without libFuzzer: "ok-*" seeds must
# read to the end, "bad-*" seeds must be rejected.
add_executable(gcode_fuzz_replay ${EF_GCODE_DIR}/fuzz/fuzz_gcode.c)
target_compile_definitions(gcode_fuzz_replay PRIVATE EF_FUZZ_REPLAY_MAIN)
target_link_libraries(gcode_fuzz_replay PRIVATE ef_host m)
add_test(NAME gcode_fuzz_replay COMMAND gcode_fuzz_replay ${EF_GCODE_DIR}/fuzz/corpus_gcode
                                         ${PROJECT_SOURCE_DIR}/tests/data/gcode)

# libFuzzer target (tests/fuzz/run.sh gcode). The host library is rebuilt from its own
# sources with coverage and sanitizer instrumentation, as the table fuzzer does for ef_fw.
if(EF_FUZZ)
  set(EF_GCODE_FUZZ_SAN -fsanitize=address,undefined -fno-sanitize-recover=all
      -fno-omit-frame-pointer)
  get_target_property(EF_GCODE_HOST_DIR ef_host SOURCE_DIR)
  add_executable(fuzz_gcode ${EF_GCODE_DIR}/fuzz/fuzz_gcode.c
                            ${EF_GCODE_HOST_DIR}/lib/program/ef_gcode.c ${EF_GCODE_HOST_DIR}/lib/program/ef_gcode_cycle.c
                            ${EF_GCODE_HOST_DIR}/lib/program/ef_gcode_flow.c ${EF_GCODE_HOST_DIR}/lib/program/ef_gcode_machine.c
                            ${EF_GCODE_HOST_DIR}/lib/core/ef_host.c)
  target_include_directories(fuzz_gcode PRIVATE ${EF_GCODE_HOST_DIR}/include
                             ${PROJECT_SOURCE_DIR}/firmware/include)
  target_compile_definitions(fuzz_gcode PRIVATE _DEFAULT_SOURCE _GNU_SOURCE
                             EF_GCODE_MAX_ITER=20000)
  target_compile_options(fuzz_gcode PRIVATE -fsanitize=fuzzer ${EF_GCODE_FUZZ_SAN})
  target_link_options(fuzz_gcode PRIVATE -fsanitize=fuzzer ${EF_GCODE_FUZZ_SAN})
  target_link_libraries(fuzz_gcode PRIVATE m)
endif()

# Reference corpus (tests/data/gcode): each NAME.ngc with its expected path NAME.path, in
# the normalized form of tests/program/gcode_ref.py. gcode_path_NAME checks evenfeed's
# reading; gcode_lcnc_NAME checks the expectation against LinuxCNC's rs274 for programs
# marked "(ref: linuxcnc)" in their first lines (skipped where rs274 is not installed).
find_package(Python3 COMPONENTS Interpreter)
if(Python3_Interpreter_FOUND)
  set(EF_GCODE_REF ${EF_GCODE_DIR}/program/gcode_ref.py)
  set(EF_GCODE_DATA ${PROJECT_SOURCE_DIR}/tests/data/gcode)
  file(GLOB EF_GCODE_PATHS CONFIGURE_DEPENDS ${EF_GCODE_DATA}/*.path)
  foreach(EF_GCODE_PATH ${EF_GCODE_PATHS})
    get_filename_component(EF_GCODE_NAME ${EF_GCODE_PATH} NAME_WE)
    set(EF_GCODE_NGC ${EF_GCODE_DATA}/${EF_GCODE_NAME}.ngc)
    add_test(NAME gcode_path_${EF_GCODE_NAME}
             COMMAND ${Python3_EXECUTABLE} ${EF_GCODE_REF} check $<TARGET_FILE:evenfeed>
                     ${EF_GCODE_NGC} ${EF_GCODE_PATH})
    set_tests_properties(gcode_path_${EF_GCODE_NAME} PROPERTIES LABELS gcode_path)
    file(READ ${EF_GCODE_NGC} EF_GCODE_HEAD LIMIT 200)
    if(EF_GCODE_HEAD MATCHES "^([^\n]*\n)?\\(ref: linuxcnc\\)")
      add_test(NAME gcode_lcnc_${EF_GCODE_NAME}
               COMMAND ${Python3_EXECUTABLE} ${EF_GCODE_REF} check-ref ${EF_GCODE_NGC}
                       ${EF_GCODE_PATH})
      set_tests_properties(gcode_lcnc_${EF_GCODE_NAME} PROPERTIES SKIP_RETURN_CODE 77
                           LABELS gcode_lcnc)
    endif()
  endforeach()
endif()

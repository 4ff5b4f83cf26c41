# SPDX-License-Identifier: Apache-2.0
# The streaming smoother (firmware ef_smooth) end to end against the default tables:
# invariants of every run, deviation measured independently, vertex rules, bad input.
if(TARGET ef_tables_default)
  add_executable(test_smooth ${CMAKE_CURRENT_SOURCE_DIR}/motion/test_smooth.c)
  target_link_libraries(test_smooth PRIVATE ef_fw ef_tables_default m)
  add_test(NAME fw_smooth COMMAND test_smooth)
  set_tests_properties(fw_smooth PROPERTIES TIMEOUT 600)
endif()

# The runtime chain under hostile input (tests/fuzz/fuzz_smooth.c): seed corpus replay in
# the ordinary builds, the libFuzzer target with EF_FUZZ (tests/fuzz/run.sh smooth).
if(TARGET ef_tables_default)
  add_executable(smooth_fuzz_replay fuzz/fuzz_smooth.c)
  target_compile_definitions(smooth_fuzz_replay PRIVATE EF_FUZZ_REPLAY_MAIN)
  target_link_libraries(smooth_fuzz_replay PRIVATE ef_fw ef_tables_default m)
  add_test(NAME fw_smooth_fuzz_replay
           COMMAND smooth_fuzz_replay ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/corpus_smooth)
  set_tests_properties(fw_smooth_fuzz_replay PROPERTIES TIMEOUT 300)
  if(EF_FUZZ)
    # Firmware and tables from their own sources, instrumented (ef_fw_fuzz: tfile.cmake).
    add_executable(fuzz_smooth fuzz/fuzz_smooth.c
                   ${PROJECT_SOURCE_DIR}/tables/gen/ef_tbl_g1_default.c
                   ${PROJECT_SOURCE_DIR}/tables/gen/ef_tbl_g2_default.c)
    target_compile_options(fuzz_smooth PRIVATE -fsanitize=fuzzer ${EF_FUZZ_SAN})
    target_link_options(fuzz_smooth PRIVATE -fsanitize=fuzzer ${EF_FUZZ_SAN})
    target_link_libraries(fuzz_smooth PRIVATE ef_fw_fuzz m)
  endif()
endif()

# Auxiliary axes (A B C U V W) through smoother, planner and interpolator
# (tests/motion/test_axes.c).
if(TARGET ef_tables_default)
  add_executable(test_axes ${CMAKE_CURRENT_SOURCE_DIR}/motion/test_axes.c)
  target_include_directories(test_axes PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(test_axes PRIVATE ef_fw ef_tables_default m)
  add_test(NAME fw_axes COMMAND test_axes)
  set_tests_properties(fw_axes PROPERTIES TIMEOUT 300)
endif()

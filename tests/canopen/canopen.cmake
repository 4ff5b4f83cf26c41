# SPDX-License-Identifier: Apache-2.0
# CANopen helpers and the segment-mode codec (firmware ef_can.c, ef_canopen.c).
add_executable(test_canopen ${CMAKE_CURRENT_SOURCE_DIR}/canopen/test_canopen.c)
target_link_libraries(test_canopen PRIVATE ef_fw m)
foreach(part bits words codec)
  add_test(NAME fw_canopen_${part} COMMAND test_canopen ${part})
endforeach()

# CAN bus-load benchmark: CSP at 1 kHz against segment mode (docs/benchmarks-can.md).
if(TARGET ef_tables_default)
  add_executable(bench_canbus ${CMAKE_CURRENT_SOURCE_DIR}/bench/bench_canbus.c)
  target_include_directories(bench_canbus PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(bench_canbus PRIVATE ef_host ef_tables_default m)
endif()

# CANopen frame handling under hostile bus input (tests/fuzz/fuzz_canopen.c): seed corpus
# replay in the ordinary builds, the libFuzzer target with EF_FUZZ (tests/fuzz/run.sh can).
add_executable(canopen_fuzz_replay fuzz/fuzz_canopen.c)
target_compile_definitions(canopen_fuzz_replay PRIVATE EF_FUZZ_REPLAY_MAIN)
target_link_libraries(canopen_fuzz_replay PRIVATE ef_fw m)
add_test(NAME fw_canopen_fuzz_replay
         COMMAND canopen_fuzz_replay ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/corpus_canopen)
if(EF_FUZZ)
  add_executable(fuzz_canopen fuzz/fuzz_canopen.c)
  target_compile_options(fuzz_canopen PRIVATE -fsanitize=fuzzer ${EF_FUZZ_SAN})
  target_link_options(fuzz_canopen PRIVATE -fsanitize=fuzzer ${EF_FUZZ_SAN})
  target_link_libraries(fuzz_canopen PRIVATE ef_fw_fuzz m)
endif()

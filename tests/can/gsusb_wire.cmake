# SPDX-License-Identifier: Apache-2.0
# The gs_usb codec (host/lib/can/ef_gsusb_wire.c): layouts, refusals, bit timing; and the
# fuzz target for what an adapter sends (tests/fuzz/fuzz_gsusb.c): its seed corpus replayed
# in the ordinary builds, the libFuzzer target with EF_FUZZ (tests/fuzz/run.sh gsusb).
add_executable(test_gsusb_wire ${CMAKE_CURRENT_SOURCE_DIR}/can/test_gsusb_wire.c)
target_include_directories(test_gsusb_wire PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_gsusb_wire PRIVATE ef_host)
foreach(part frame replies bittiming)
  add_test(NAME gsusb_wire_${part} COMMAND test_gsusb_wire ${part})
endforeach()

add_executable(gsusb_fuzz_replay ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/fuzz_gsusb.c)
target_compile_definitions(gsusb_fuzz_replay PRIVATE EF_FUZZ_REPLAY_MAIN)
target_link_libraries(gsusb_fuzz_replay PRIVATE ef_host)
add_test(NAME gsusb_fuzz_replay
         COMMAND gsusb_fuzz_replay ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/corpus_gsusb)
if(EF_FUZZ)
  set(EF_GSUSB_FUZZ_SAN -fsanitize=address,undefined -fno-sanitize-recover=all
      -fno-omit-frame-pointer)
  add_executable(fuzz_gsusb ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/fuzz_gsusb.c
                            ${PROJECT_SOURCE_DIR}/host/lib/can/ef_gsusb_wire.c
                            ${PROJECT_SOURCE_DIR}/host/lib/core/ef_host.c)
  target_include_directories(fuzz_gsusb PRIVATE ${PROJECT_SOURCE_DIR}/host/include
                             ${PROJECT_SOURCE_DIR}/firmware/include)
  target_compile_definitions(fuzz_gsusb PRIVATE _DEFAULT_SOURCE _GNU_SOURCE)
  target_compile_options(fuzz_gsusb PRIVATE -fsanitize=fuzzer ${EF_GSUSB_FUZZ_SAN})
  target_link_options(fuzz_gsusb PRIVATE -fsanitize=fuzzer ${EF_GSUSB_FUZZ_SAN})
endif()

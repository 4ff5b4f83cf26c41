# SPDX-License-Identifier: Apache-2.0
# CANopen CiA 402 drive (firmware ef_codrive): NMT and heartbeat, the SDO server and its
# aborts, PDO configuration, the power state machine, CSP, segment mode end to end through
# the ef_canopen codec, faults and EMCY, feed hold (halt), the TX queue, malformed frames, the SYNC-loss watchdog.
add_executable(test_codrive ${CMAKE_CURRENT_SOURCE_DIR}/canopen/test_codrive.c)
target_link_libraries(test_codrive PRIVATE ef_fw m)
foreach(part nmt sdo pdo power csp segment faults bad tx watchdog txq hold)
  add_test(NAME fw_codrive_${part} COMMAND test_codrive ${part})
endforeach()

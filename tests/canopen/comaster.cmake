# SPDX-License-Identifier: Apache-2.0
# CANopen master (firmware ef_comaster): scripted fake-drive tests of bring-up, SDO errors,
# refusals, TX retries and bus errors, the caller's SDO client; integration with real
# ef_codrive drives, each on its own pump, on the in-memory bus (ef_canrig.h: CSP, segment
# mode, its feed hold, go-back-N, EMCY, heartbeat loss, a master starved of CPU time, a dead node).
add_executable(test_comaster ${CMAKE_CURRENT_SOURCE_DIR}/canopen/test_comaster.c)
target_link_libraries(test_comaster PRIVATE ef_host ef_fw ef_tables_default m)
foreach(part args fake_csp fake_seg boot abort devtype sdo_timeout malformed fault again bus
             csp seg seg_axes csp_axes seg_hold gobackn gobackn_pending resend_limit emcy heartbeat starved
             heartbeat_all node_dead
             sdo_segdl_fake sdo_user sdo_client)
  add_test(NAME fw_comaster_${part} COMMAND test_comaster ${part})
endforeach()

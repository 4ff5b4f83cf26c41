# CANopen master (firmware ef_comaster): scripted fake-drive tests of bring-up, SDO errors,
# refusals, TX retries and bus errors; integration with real ef_codrive drives on the
# in-memory bus of ef_canbus_sim.h (CSP, segment mode, go-back-N, EMCY, heartbeat loss).
add_executable(test_comaster test_comaster.c)
target_link_libraries(test_comaster PRIVATE ef_fw m)
foreach(part args fake_csp fake_seg boot abort devtype sdo_timeout malformed fault again bus
             csp seg gobackn emcy heartbeat)
  add_test(NAME fw_comaster_${part} COMMAND test_comaster ${part})
endforeach()

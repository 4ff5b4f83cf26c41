# CANopen helpers and the segment-mode codec (firmware ef_can.c, ef_canopen.c).
add_executable(test_canopen test_canopen.c)
target_link_libraries(test_canopen PRIVATE ef_fw m)
foreach(part bits words codec)
  add_test(NAME fw_canopen_${part} COMMAND test_canopen ${part})
endforeach()

# CAN bus-load benchmark: CSP at 1 kHz against segment mode (docs/benchmarks-can.md).
if(TARGET ef_tables_default)
  add_executable(bench_canbus ${CMAKE_CURRENT_LIST_DIR}/bench/bench_canbus.c)
  target_include_directories(bench_canbus PRIVATE ${CMAKE_CURRENT_LIST_DIR})
  target_link_libraries(bench_canbus PRIVATE ef_host ef_tables_default m)
endif()

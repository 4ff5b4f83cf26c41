# SPDX-License-Identifier: Apache-2.0
# Modbus transport end to end (docs/modbus.md): the master and the simulated drive on
# libmodbus, over TCP on loopback and RTU on a socat pseudo-terminal pair. Test names start
# with "modbus" (ctest -R modbus).
if(TARGET ef_tables_default)
  add_executable(test_modbus ${CMAKE_CURRENT_SOURCE_DIR}/modbus/test_modbus.c)
  target_include_directories(test_modbus PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(test_modbus PRIVATE ef_host ef_tables_default m)
  foreach(part bad tcp rtu faults direct codec axes axesfault axesbad axesrtu)
    add_test(NAME modbus_${part}
             COMMAND test_modbus $<TARGET_FILE:evenfeed> ${PROJECT_SOURCE_DIR}
                     ${CMAKE_CURRENT_BINARY_DIR} ${part})
    set_tests_properties(modbus_${part} PROPERTIES TIMEOUT 300)
  endforeach()
endif()

# Throughput benchmark (tests/bench/run_all.sh; figures, not a test).
if(TARGET ef_tables_default)
  add_executable(bench_modbus ${CMAKE_CURRENT_SOURCE_DIR}/bench/bench_modbus.c)
  target_include_directories(bench_modbus PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(bench_modbus PRIVATE ef_host ef_tables_default m)
endif()

# The CLI: argument errors, an unreachable drive, a whole program streamed.
add_test(NAME modbus_cli
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/modbus/test_stream_cli.sh $<TARGET_FILE:evenfeed>
                 ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(modbus_cli PROPERTIES TIMEOUT 120 PASS_REGULAR_EXPRESSION " 0 failed")

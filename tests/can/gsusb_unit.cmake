# SPDX-License-Identifier: Apache-2.0
# gs_usb USB-CAN transport (host/lib/can/ef_gsusb.c): the parts that need no adapter, in the
# ordinary (sanitized) build. The adapter itself is tested against the simulated one in
# User-Mode Linux (hil_gsusb_*).
add_executable(test_gsusb ${CMAKE_CURRENT_SOURCE_DIR}/can/test_gsusb.c)
target_include_directories(test_gsusb PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_gsusb PRIVATE ef_host)
add_test(NAME gsusb_offline COMMAND test_gsusb)
set_tests_properties(gsusb_offline PROPERTIES TIMEOUT 30)

# The CLI: `evenfeed can list` with no adapter, malformed --can gsusb specs.
add_test(NAME gsusb_cli
         COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/can/test_gsusb_cli.sh $<TARGET_FILE:evenfeed>
                 ${PROJECT_SOURCE_DIR})
set_tests_properties(gsusb_cli PROPERTIES TIMEOUT 60 PASS_REGULAR_EXPRESSION " 0 failed")

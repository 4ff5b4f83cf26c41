# SPDX-License-Identifier: Apache-2.0
# Drive side (firmware ef_drive, ef_modbus): the slot codec and CRC, the drive executing
# streamed segments with its servo model, and the Modbus register device.
add_executable(test_drive ${CMAKE_CURRENT_SOURCE_DIR}/drive/test_drive.c)
target_link_libraries(test_drive PRIVATE ef_fw m)
add_test(NAME fw_drive_codec COMMAND test_drive codec)
add_test(NAME fw_drive_exec COMMAND test_drive exec)
add_test(NAME fw_drive_stop COMMAND test_drive stop)
add_test(NAME fw_drive_hold COMMAND test_drive hold)
add_test(NAME fw_drive_mbdev COMMAND test_drive mbdev)

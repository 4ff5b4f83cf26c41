# SPDX-License-Identifier: Apache-2.0
# Firmware unit tests (synthetic tables; no optimizer needed).
add_executable(test_fw ${CMAKE_CURRENT_SOURCE_DIR}/core/test_fw.c)
target_link_libraries(test_fw PRIVATE ef_fw m)
add_test(NAME fw_unit COMMAND test_fw)

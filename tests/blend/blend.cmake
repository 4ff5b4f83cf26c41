# SPDX-License-Identifier: Apache-2.0
# Corner blends (firmware ef_blend_corner) against the shipped default G2 table.
if(TARGET ef_tables_default)
  add_executable(test_blend ${CMAKE_CURRENT_SOURCE_DIR}/blend/test_blend.c)
  target_link_libraries(test_blend PRIVATE ef_fw ef_tables_default m)
  add_test(NAME fw_blend COMMAND test_blend)
endif()

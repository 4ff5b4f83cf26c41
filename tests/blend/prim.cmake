# SPDX-License-Identifier: Apache-2.0
# Path primitives (ef_prim_check, ef_prim_frame, ef_move_measure), arc pieces and corner
# blends with arc/helix ends (ef_blend_arc_piece, ef_blend_prims) against the default G2 table.
if(TARGET ef_tables_default)
  add_executable(test_prim ${CMAKE_CURRENT_SOURCE_DIR}/blend/test_prim.c)
  target_link_libraries(test_prim PRIVATE ef_fw ef_tables_default m)
  # The test's own double-precision reference measurements (dense sampling of thousands of
  # blends) dominate its run time; optimize them even in Debug builds (the firmware library
  # keeps the build type's flags).
  target_compile_options(test_prim PRIVATE -O2)
  add_test(NAME fw_prim COMMAND test_prim)
endif()

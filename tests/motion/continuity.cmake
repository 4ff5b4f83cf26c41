# SPDX-License-Identifier: Apache-2.0
# Setpoint continuity (issue 18): generated programs through the whole host pipeline, every
# setpoint's per-axis acceleration and jerk checked against the limits (ef_sp_check.h).
# One ctest per part, so a failure names the program kind (ctest -R continuity).
if(TARGET ef_tables_default)
  add_executable(test_continuity ${CMAKE_CURRENT_SOURCE_DIR}/motion/test_continuity.c)
  target_compile_definitions(test_continuity PRIVATE EF_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  target_link_libraries(test_continuity PRIVATE ef_host ef_tables_default m)
  # `uniform`: the same programs with uniform parameter stepping, what ef_drive.c executes
  # in segment mode (every curve's end speeds equal its length, ef_seg_g2_even(), so the
  # feed is continuous at the junctions there too)
  foreach(part checker cam runs arcs feeds overfeed tangent qcircle zigzag far junction uniform
          file)
    add_test(NAME continuity_${part} COMMAND test_continuity ${part})
    set_tests_properties(continuity_${part} PROPERTIES TIMEOUT 600)
  endforeach()
endif()

# SPDX-License-Identifier: Apache-2.0
# Setpoint continuity (issue 18): generated programs through the whole host pipeline, every
# setpoint's per-axis acceleration and jerk checked against the limits (ef_sp_check.h).
# One ctest per part, so a failure names the program kind (ctest -R continuity).
if(TARGET ef_tables_default)
  add_executable(test_continuity ${CMAKE_CURRENT_SOURCE_DIR}/motion/test_continuity.c)
  target_compile_definitions(test_continuity PRIVATE EF_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  target_link_libraries(test_continuity PRIVATE ef_host ef_tables_default m)
  foreach(part checker cam runs arcs feeds overfeed tangent qcircle zigzag far junction file)
    add_test(NAME continuity_${part} COMMAND test_continuity ${part})
    set_tests_properties(continuity_${part} PROPERTIES TIMEOUT 600)
  endforeach()
  # Not a ctest yet: the part `uniform` (the same programs with uniform parameter stepping,
  # what ef_drive.c executes in segment mode) still fails on jerk at blend junctions, where
  # the blend's parametric speed |f'| / L differs from 1 (open item of issue 18; the
  # benchmarks print its figure: tests/bench/run_all.sh).
endif()

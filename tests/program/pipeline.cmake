# SPDX-License-Identifier: Apache-2.0
# Host pipeline and `evenfeed smooth` (docs/smoothing-cli.md): conversions, exact stops,
# events, notes, refused input, the sample program end to end, and the CLI's outputs.
# Test names start with "pipeline" (ctest -R pipeline).
if(TARGET ef_tables_default)
  add_executable(test_pipeline ${CMAKE_CURRENT_SOURCE_DIR}/program/test_pipeline.c)
  target_include_directories(test_pipeline PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_compile_definitions(test_pipeline PRIVATE EF_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  target_link_libraries(test_pipeline PRIVATE ef_host ef_tables_default m)
  add_test(NAME pipeline_unit COMMAND test_pipeline)
  set_tests_properties(pipeline_unit PROPERTIES TIMEOUT 600)

  add_test(NAME pipeline_cli
           COMMAND bash ${CMAKE_CURRENT_SOURCE_DIR}/program/test_smooth_cli.sh $<TARGET_FILE:evenfeed>
                   ${PROJECT_SOURCE_DIR})
  set_tests_properties(pipeline_cli PROPERTIES TIMEOUT 600 PASS_REGULAR_EXPRESSION " 0 failed")
  # The demo needs no input file and writes its SVG where it is told.
  add_test(NAME pipeline_demo
           COMMAND sh -c "$<TARGET_FILE:evenfeed> demo --svg \"$1.svg\" && test -s \"$1.svg\" && test -s \"$1-profile.svg\"" sh
                   ${CMAKE_CURRENT_BINARY_DIR}/pipeline-demo)
  # Both programs: the profile's micro-segments become smooth sections, within P; the CAN
  # part: every drive executed every segment of the profile.
  set_tests_properties(pipeline_demo PROPERTIES TIMEOUT 600
                       PASS_REGULAR_EXPRESSION "SVG plot written to .*pipeline-demo.svg.*vertices [^\n]* [1-9][0-9]* smooth\ndeviation [^\n]*, 0 moves over tolerance.*SVG plot written to .*pipeline-demo-profile.svg.*executed by each drive: 142 142 142.*segment mode needs 1/")
endif()

# Regression: a very short arc between two corners (both blends use it up) must not stop
# the smoother; the whole program comes out, ending at rest at its last point.
if(TARGET ef_tables_default)
  add_test(NAME pipeline_short_arc
           COMMAND evenfeed smooth ${CMAKE_CURRENT_SOURCE_DIR}/data/short_arc.ngc)
  set_tests_properties(pipeline_short_arc PROPERTIES
                       PASS_REGULAR_EXPRESSION "end position +63.5911 50.9075 -1.0000")
endif()

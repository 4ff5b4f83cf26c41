# SPDX-License-Identifier: Apache-2.0
# Feed planner (ef_plan) and interpolator (ef_interp): synthetic moves, no tables needed.
add_executable(test_plan ${CMAKE_CURRENT_SOURCE_DIR}/motion/test_plan.c)
target_link_libraries(test_plan PRIVATE ef_fw m)
add_test(NAME fw_plan COMMAND test_plan plan)
add_test(NAME fw_interp COMMAND test_plan interp)
add_test(NAME fw_plan_bad COMMAND test_plan bad)

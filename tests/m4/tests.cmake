# SPDX-License-Identifier: Apache-2.0
# ctest tests of the images of tests/m4 (included by tests/m4/m4.cmake).

# Costs and stack (tests/m4/costs_tests.cmake).
include(${CMAKE_CURRENT_LIST_DIR}/costs_tests.cmake)

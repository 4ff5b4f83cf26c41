# SPDX-License-Identifier: Apache-2.0
# Images of tests/m4 for the M4 project (included by firmware/arm/m4/CMakeLists.txt).

# Costs (tests/m4/costs_images.cmake).
include(${EF_TOP}/tests/m4/costs_images.cmake)

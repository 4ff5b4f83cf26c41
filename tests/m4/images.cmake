# SPDX-License-Identifier: Apache-2.0
# Images of tests/m4 for the M4 project (included by firmware/arm/m4/CMakeLists.txt).

# Golden cases (golden.h): the same source as the host's golden_host, with the programs the
# host generated into EF_M4_GEN_DIR (tests/m4/host.cmake).
if(EF_M4_GEN_DIR AND EXISTS ${EF_M4_GEN_DIR}/golden_progs.c)
  ef_m4_image(m4_golden ${EF_TOP}/tests/m4/golden.c ${EF_TOP}/tests/m4/golden_m4.c
              ${EF_M4_GEN_DIR}/golden_progs.c)
  target_include_directories(m4_golden PRIVATE ${EF_TOP}/tests/m4)
  target_link_libraries(m4_golden PRIVATE ef_m4_tables)
  target_compile_options(m4_golden PRIVATE -ffreestanding -fno-math-errno -ffp-contract=off)
endif()

# Costs (tests/m4/costs_images.cmake).
include(${EF_TOP}/tests/m4/costs_images.cmake)

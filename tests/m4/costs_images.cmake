# SPDX-License-Identifier: Apache-2.0
# The costs image (tests/m4/m4_costs.c; included by tests/m4/images.cmake): instructions per
# call and stack high-water of the per-move functions, on the inputs of tests/bench/ct_cases.h.
# With the sample programs' streams when the host generated them (golden_progs.c,
# tests/m4/golden_gen.c).
ef_m4_image(m4_costs ${EF_TOP}/tests/m4/m4_costs.c)
target_include_directories(m4_costs PRIVATE ${EF_TOP}/tests/m4 ${EF_TOP}/tests/bench)
target_link_libraries(m4_costs PRIVATE ef_m4_tables m)
if(EF_M4_GEN_DIR AND EXISTS ${EF_M4_GEN_DIR}/golden_progs.c)
  target_sources(m4_costs PRIVATE ${EF_M4_GEN_DIR}/golden_progs.c)
  target_compile_definitions(m4_costs PRIVATE COSTS_PROGS)
endif()

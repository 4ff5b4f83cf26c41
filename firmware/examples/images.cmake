# SPDX-License-Identifier: Apache-2.0
# The integration example (firmware/examples/README.md) for the M4 project (included by
# firmware/arm/m4/CMakeLists.txt when present).
#
# It runs at icount shift 3 (qemu_run.sh --shift 3: 8 ns per instruction, 125 000
# instructions per millisecond), so it needs the board support compiled for that shift: the
# instruction counter converts timer ticks with EF_M4_ICOUNT_SHIFT at compile time. The
# variant's objects are linked into the image directly, so the linker never pulls the
# shift-10 ef_m4_board members that ef_m4_image() also names.
set(EF_EXAMPLE_SHIFT 3)
if(EF_M4_GEN_DIR AND EXISTS ${EF_M4_GEN_DIR}/golden_progs.c)
  add_library(ef_m4_board_s${EF_EXAMPLE_SHIFT} OBJECT
              ${EF_TOP}/firmware/arm/m4/ef_m4.c
              ${EF_TOP}/firmware/arm/m4/ef_m4_startup.c)
  target_include_directories(ef_m4_board_s${EF_EXAMPLE_SHIFT} PUBLIC ${EF_TOP}/firmware/arm/m4)
  target_compile_definitions(ef_m4_board_s${EF_EXAMPLE_SHIFT} PUBLIC
                             EF_M4_ICOUNT_SHIFT=${EF_EXAMPLE_SHIFT})
  target_compile_options(ef_m4_board_s${EF_EXAMPLE_SHIFT} PRIVATE -ffreestanding)

  # The sample programs' primitive records, as the golden test generated them.
  ef_m4_image(m4_example ${EF_TOP}/firmware/examples/m4_loop.c ${EF_M4_GEN_DIR}/golden_progs.c)
  target_include_directories(m4_example PRIVATE ${EF_TOP}/tests/m4)
  target_link_libraries(m4_example PRIVATE ef_m4_board_s${EF_EXAMPLE_SHIFT} ef_m4_tables)
  target_compile_options(m4_example PRIVATE -ffreestanding -fno-math-errno -ffp-contract=off)
endif()

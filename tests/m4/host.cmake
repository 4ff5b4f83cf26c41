# SPDX-License-Identifier: Apache-2.0
# Host side of the M4 images (included by tests/m4/m4.cmake): generators that write into
# EF_M4_GEN_DIR before the images are built (appended to EF_M4_GEN_TARGETS), and the host
# builds of the images' sources.

# Golden cases (golden.h): the sample programs' primitive streams, read by the host G-code
# reader once (golden_gen), compiled into both the M4 image m4_golden and golden_host.
if(TARGET ef_host AND TARGET ef_tables_default)
  add_executable(golden_gen ${CMAKE_CURRENT_LIST_DIR}/golden_gen.c)
  target_include_directories(golden_gen PRIVATE ${CMAKE_CURRENT_LIST_DIR})
  target_link_libraries(golden_gen PRIVATE ef_host ef_fw m)
  set(EF_GOLDEN_PROGS ${EF_M4_GEN_DIR}/golden_progs.c)
  set(EF_GOLDEN_ARGS profile=${PROJECT_SOURCE_DIR}/samples/profile.ngc
                     bracket=${PROJECT_SOURCE_DIR}/samples/bracket.ngc)
  set(EF_GOLDEN_DEPS ${PROJECT_SOURCE_DIR}/samples/profile.ngc
                     ${PROJECT_SOURCE_DIR}/samples/bracket.ngc)
  if(TARGET gen_cam)
    # A CAM-like program of the smoothing benchmark (tests/bench/gen_cam.c), 3000 lines.
    add_custom_command(OUTPUT ${EF_M4_GEN_DIR}/golden_cam.ngc
      COMMAND gen_cam -n 3000 -s 1 -o ${EF_M4_GEN_DIR}/golden_cam.ngc
      DEPENDS gen_cam VERBATIM)
    list(APPEND EF_GOLDEN_ARGS cam=${EF_M4_GEN_DIR}/golden_cam.ngc)
    list(APPEND EF_GOLDEN_DEPS ${EF_M4_GEN_DIR}/golden_cam.ngc)
  endif()
  add_custom_command(OUTPUT ${EF_GOLDEN_PROGS}
    COMMAND golden_gen ${EF_GOLDEN_PROGS} ${EF_GOLDEN_ARGS}
    DEPENDS golden_gen ${EF_GOLDEN_DEPS} VERBATIM)
  add_custom_target(m4_golden_gen DEPENDS ${EF_GOLDEN_PROGS})
  list(APPEND EF_M4_GEN_TARGETS m4_golden_gen)

  add_executable(golden_host ${CMAKE_CURRENT_LIST_DIR}/golden.c
                             ${CMAKE_CURRENT_LIST_DIR}/golden_host.c ${EF_GOLDEN_PROGS})
  target_include_directories(golden_host PRIVATE ${CMAKE_CURRENT_LIST_DIR})
  target_link_libraries(golden_host PRIVATE ef_fw ef_tables_default)
  # As the firmware is built (firmware/README.md): ef_sqrtf() is the square-root instruction,
  # nothing contracted into a fused multiply-add (the inline vector helpers compile here).
  target_compile_options(golden_host PRIVATE -ffreestanding -fno-math-errno -ffp-contract=off
                                             -Wdouble-promotion)
endif()

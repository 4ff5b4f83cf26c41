# SPDX-License-Identifier: Apache-2.0
# Agreement of the compute shader (gpu_offline/shaders/ef_opt.comp) with the CPU reference,
# through ef_gl.h; on CI it runs on llvmpipe. Only when the GL builder (ef_gpu) is built;
# exits 77 (skipped) when no headless GL context can be made.
if(TARGET ef_gpu)
  add_executable(test_gl ${CMAKE_CURRENT_SOURCE_DIR}/table/test_gl.c)
  target_include_directories(test_gl PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(test_gl PRIVATE ef_gpu ef_host m)
  add_test(NAME gl_agree COMMAND test_gl)
  # llvmpipe compiles the G2 shader in a few seconds; ASan slows the CPU side.
  set_tests_properties(gl_agree PROPERTIES SKIP_RETURN_CODE 77 TIMEOUT 300)
endif()

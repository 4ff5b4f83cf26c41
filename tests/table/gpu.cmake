# SPDX-License-Identifier: Apache-2.0
# The headless GL context (gpu_offline/src/ef_gl.c); only when the GL builder is built.
if(TARGET ef_gpu)
  add_executable(test_gl_open ${CMAKE_CURRENT_SOURCE_DIR}/table/test_gl_open.c)
  target_link_libraries(test_gl_open PRIVATE ef_gpu)
  add_test(NAME gl_open COMMAND test_gl_open ok)
  set_tests_properties(gl_open PROPERTIES SKIP_RETURN_CODE 77)
  # A driver without GL 4.3 (Mesa told to offer 3.3) and a missing EGL device.
  add_test(NAME gl_open_no43 COMMAND test_gl_open expect-fail "4.3")
  set_tests_properties(gl_open_no43 PROPERTIES ENVIRONMENT "MESA_GL_VERSION_OVERRIDE=3.3")
  add_test(NAME gl_open_nodevice COMMAND test_gl_open expect-fail "not found")
  set_tests_properties(gl_open_nodevice PROPERTIES ENVIRONMENT "EF_GL_PLATFORM=device;EF_GL_DEVICE=99")
endif()

# The compute shader compiles for both kinds (glslangValidator, no GL context needed).
find_program(EF_GLSLANG glslangValidator)
if(EF_GLSLANG)
  foreach(kind 1 2)
    add_test(NAME gl_shader_compiles_kind${kind}
             COMMAND ${CMAKE_COMMAND} -DVALIDATOR=${EF_GLSLANG}
                     -DSHADER=${PROJECT_SOURCE_DIR}/gpu_offline/shaders/ef_opt.comp -DKIND=${kind}
                     -DOUT=${CMAKE_CURRENT_BINARY_DIR}
                     -P ${PROJECT_SOURCE_DIR}/gpu_offline/cmake/validate.cmake)
  endforeach()
endif()

# Benchmark (prints figures): GL builder against the CPU builder on the same grids.
if(TARGET ef_gpu)
  add_executable(bench_build bench/bench_build.c)
  target_link_libraries(bench_build PRIVATE ef_gpu)
endif()

# SPDX-License-Identifier: Apache-2.0
# Check the compute shader compiles for a kind with glslangValidator (no GL context needed).
# Usage: cmake -DVALIDATOR=... -DSHADER=... -DKIND=1 -DOUT=dir -P validate.cmake
# The preamble must match gl_program() in gpu_offline/src/ef_gl.c.
file(READ "${SHADER}" body)
set(src "#version 430\n#extension GL_ARB_gpu_shader_fp64 : require\n#define EF_KIND ${KIND}\n#define EF_LOCAL_SIZE 32\n#define EF_CFG_STRIDE 8\n#line 1\n${body}")
file(WRITE "${OUT}/ef_opt_kind${KIND}.comp" "${src}")
execute_process(COMMAND "${VALIDATOR}" -S comp "${OUT}/ef_opt_kind${KIND}.comp"
                RESULT_VARIABLE rc OUTPUT_VARIABLE out ERROR_VARIABLE err)
if(NOT rc EQUAL 0)
  message(FATAL_ERROR "shader kind ${KIND} does not compile:\n${out}${err}")
endif()
message(STATUS "shader kind ${KIND}: compiles")

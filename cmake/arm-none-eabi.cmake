# SPDX-License-Identifier: Apache-2.0
# Toolchain file for a Cortex-M4F (ARMv7E-M, single-precision FPU, hard-float ABI) with the
# GNU Arm Embedded toolchain (Debian: gcc-arm-none-eabi, libnewlib-arm-none-eabi).
#
#   cmake -S firmware -B build-arm -G Ninja -DCMAKE_TOOLCHAIN_FILE=cmake/arm-none-eabi.cmake \
#         -DCMAKE_BUILD_TYPE=MinSizeRel
#
# Only the firmware is meant for this target (the host library needs a hosted libc and
# double-precision libm); firmware/arm/build.sh wraps the configure, build and link check.
set(CMAKE_SYSTEM_NAME Generic)
set(CMAKE_SYSTEM_PROCESSOR arm)

set(EF_ARM_PREFIX arm-none-eabi- CACHE STRING "Cross tool prefix")
set(CMAKE_C_COMPILER ${EF_ARM_PREFIX}gcc)
set(CMAKE_ASM_COMPILER ${EF_ARM_PREFIX}gcc)
find_program(CMAKE_AR ${EF_ARM_PREFIX}ar)
find_program(CMAKE_RANLIB ${EF_ARM_PREFIX}ranlib)
find_program(CMAKE_OBJCOPY ${EF_ARM_PREFIX}objcopy)
find_program(CMAKE_SIZE ${EF_ARM_PREFIX}size)

# A bare-metal compiler cannot link a test executable without a board's startup code and
# linker script, so CMake's compiler check builds a static library instead.
set(CMAKE_TRY_COMPILE_TARGET_TYPE STATIC_LIBRARY)

# -mfpu=fpv4-sp-d16 -mfloat-abi=hard: float math on the FPU, float arguments in s registers
# (double would be soft-float library calls, which the firmware must not need).
# -ffunction-sections -fdata-sections let the final link drop every unused function.
set(EF_ARM_CPU_FLAGS "-mcpu=cortex-m4 -mthumb -mfpu=fpv4-sp-d16 -mfloat-abi=hard")
set(CMAKE_C_FLAGS_INIT "${EF_ARM_CPU_FLAGS} -ffunction-sections -fdata-sections")
set(CMAKE_ASM_FLAGS_INIT "${EF_ARM_CPU_FLAGS}")
set(CMAKE_EXE_LINKER_FLAGS_INIT "-Wl,--gc-sections")

# Never pick up host headers or libraries.
set(CMAKE_FIND_ROOT_PATH_MODE_PROGRAM NEVER)
set(CMAKE_FIND_ROOT_PATH_MODE_LIBRARY ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_INCLUDE ONLY)
set(CMAKE_FIND_ROOT_PATH_MODE_PACKAGE ONLY)

# SPDX-License-Identifier: Apache-2.0
# The firmware on a Cortex-M4F: the images of firmware/arm/m4/ built with Debian's
# gcc-arm-none-eabi at -O2 and at -Os (external projects: another compiler) and run by ctest
# under qemu-system-arm -M mps2-an386 (tests/m4/qemu_run.sh, a wall-clock bound each).
#
# EF_M4: AUTO (default) builds and tests them when arm-none-eabi-gcc is found; ON requires
# the toolchain and QEMU (./dev test sets it, so CI cannot pass without running them); OFF.
set(EF_M4 AUTO CACHE STRING "Cortex-M4F images under QEMU: AUTO, ON or OFF")
set_property(CACHE EF_M4 PROPERTY STRINGS AUTO ON OFF)

find_program(EF_ARM_GCC arm-none-eabi-gcc)
find_program(EF_QEMU_ARM qemu-system-arm)
set(EF_M4_ENABLED OFF)
if(EF_M4 STREQUAL "ON")
  if(NOT EF_ARM_GCC OR NOT EF_QEMU_ARM)
    message(FATAL_ERROR "EF_M4=ON needs arm-none-eabi-gcc (gcc-arm-none-eabi, "
                        "libnewlib-arm-none-eabi) and qemu-system-arm")
  endif()
  set(EF_M4_ENABLED ON)
elseif(EF_M4 STREQUAL "AUTO" AND EF_ARM_GCC)
  set(EF_M4_ENABLED ON)
endif()

if(EF_M4_ENABLED)
  include(ExternalProject)
  set(EF_M4_GEN_DIR ${CMAKE_BINARY_DIR}/m4gen)
  file(MAKE_DIRECTORY ${EF_M4_GEN_DIR})
  # Host targets that write into EF_M4_GEN_DIR before the images are built (images.cmake
  # of tests/m4 may append to it through tests/m4/host.cmake).
  set(EF_M4_GEN_TARGETS "")
  if(EXISTS ${CMAKE_CURRENT_LIST_DIR}/host.cmake)
    include(${CMAKE_CURRENT_LIST_DIR}/host.cmake)
  endif()
  set(EF_M4_REQUIRED 0)
  if(EF_M4 STREQUAL "ON")
    set(EF_M4_REQUIRED 1)
  endif()
  foreach(opt O2 Os)
    ExternalProject_Add(ef_m4_${opt}
      SOURCE_DIR ${PROJECT_SOURCE_DIR}/firmware/arm/m4
      BINARY_DIR ${CMAKE_BINARY_DIR}/m4-${opt}
      CMAKE_ARGS -DCMAKE_TOOLCHAIN_FILE=${PROJECT_SOURCE_DIR}/cmake/arm-none-eabi.cmake
                 -DCMAKE_BUILD_TYPE=Release -DEF_M4_OPT=-${opt} -DEF_WERROR=${EF_WERROR}
                 -DEF_M4_GEN_DIR=${EF_M4_GEN_DIR}
      BUILD_ALWAYS ON
      INSTALL_COMMAND ""
      DEPENDS ${EF_M4_GEN_TARGETS})
    set(EF_M4_DIR_${opt} ${CMAKE_BINARY_DIR}/m4-${opt})
    add_test(NAME m4_selftest_${opt}
             COMMAND sh ${CMAKE_CURRENT_LIST_DIR}/qemu_run.sh --limit 60
                     ${CMAKE_BINARY_DIR}/m4-${opt}/m4_selftest.elf)
    set_tests_properties(m4_selftest_${opt} PROPERTIES
      ENVIRONMENT "EF_M4_REQUIRED=${EF_M4_REQUIRED}" SKIP_RETURN_CODE 77
      PASS_REGULAR_EXPRESSION "m4_selftest: ok")
  endforeach()
  # Tests of the further images (golden digests, costs, the example).
  if(EXISTS ${CMAKE_CURRENT_LIST_DIR}/tests.cmake)
    include(${CMAKE_CURRENT_LIST_DIR}/tests.cmake)
  endif()
  if(EXISTS ${PROJECT_SOURCE_DIR}/firmware/examples/tests.cmake)
    include(${PROJECT_SOURCE_DIR}/firmware/examples/tests.cmake)
  endif()
endif()

# SPDX-License-Identifier: Apache-2.0
# GPIO lines (host/lib/io/ef_gpio.c, libgpiod 1.6). test_gpio (ef_host, sanitized like the
# rest) runs the part that needs no GPIO chip on the build host (gpio_offline); the parts on
# a gpio-sim chip run inside User-Mode Linux (hil_gpio_*, tests/hil/gpio.sh; see
# tests/can/hil.cmake for the runner, ef_hil_executable() and why the guest binary is built
# without AddressSanitizer under EF_SANITIZE). Included after tests/can/hil.cmake.
add_executable(test_gpio ${CMAKE_CURRENT_SOURCE_DIR}/io/test_gpio.c)
target_include_directories(test_gpio PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_gpio PRIVATE ef_host)
add_test(NAME gpio_offline COMMAND test_gpio offline)
set_tests_properties(gpio_offline PROPERTIES TIMEOUT 30)

# The machine file (host/lib/io/ef_mio.c): wiring, defaults, every kind of bad line.
add_executable(test_mio ${CMAKE_CURRENT_SOURCE_DIR}/io/test_mio.c)
target_include_directories(test_mio PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_mio PRIVATE ef_host)
add_test(NAME mio_cfg COMMAND test_mio ${CMAKE_CURRENT_BINARY_DIR} cfg)
set_tests_properties(mio_cfg PROPERTIES TIMEOUT 30)

# The feed-hold time warp (host/lib/io/ef_warp.c) that CSP and Modbus direct mode stream
# through: on the path, within a / 2, nothing skipped, the end exact.
add_executable(test_warp ${CMAKE_CURRENT_SOURCE_DIR}/io/test_warp.c)
target_include_directories(test_warp PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_warp PRIVATE ef_host m)
add_test(NAME warp COMMAND test_warp warp)
set_tests_properties(warp PROPERTIES TIMEOUT 60)

if(EF_SANITIZE)
  ef_hil_executable(test_gpio_uml ${CMAKE_CURRENT_SOURCE_DIR}/io/test_gpio.c
    ${PROJECT_SOURCE_DIR}/host/lib/io/ef_gpio.c ${PROJECT_SOURCE_DIR}/host/lib/core/ef_host.c)
  # Only ef_fail() of the rest is needed; ef_fw (built with ASan here) is not linked.
  # host/'s PkgConfig::GPIOD is not visible here (imported targets are directory-scoped).
  find_package(PkgConfig REQUIRED)
  pkg_check_modules(EF_HIL_GPIOD REQUIRED IMPORTED_TARGET libgpiod>=1.6)
  target_link_libraries(test_gpio_uml PRIVATE PkgConfig::EF_HIL_GPIOD)
  set(EF_GPIO_GUEST_BIN $<TARGET_FILE:test_gpio_uml>)
else()
  set(EF_GPIO_GUEST_BIN $<TARGET_FILE:test_gpio>)
endif()
foreach(part sim_open sim_errors sim_debounce sim_safe)
  add_test(NAME hil_gpio_${part}
           COMMAND bash ${EF_HIL_RUN} ${CMAKE_CURRENT_SOURCE_DIR}/hil/gpio.sh
                   ${CMAKE_CURRENT_BINARY_DIR}/hil_gpio_${part}/verdict 120
                   ${EF_GPIO_GUEST_BIN} ${part})
  set_tests_properties(hil_gpio_${part} PROPERTIES TIMEOUT 150 SKIP_RETURN_CODE 77
                       RESOURCE_LOCK uml RUN_SERIAL ON)
endforeach()

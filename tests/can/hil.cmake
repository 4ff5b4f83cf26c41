# SPDX-License-Identifier: Apache-2.0
# Hardware-in-loop tests: real kernel drivers inside User-Mode Linux (docs: see
# tests/hil/uml_run.sh and docs/hil.md). Each test boots the project's HIL kernel
# (build/hil-kernel/linux, made by tests/hil/build_kernel.sh from tests/hil/uml-hil.fragment)
# on the host's file system, runs a guest script, and passes only on the guest's PASS
# verdict; it is skipped (exit 77) where that kernel is not built, unless CI /
# EF_HIL_REQUIRE is set. Every HIL test holds RESOURCE_LOCK uml (one guest at a time) and
# runs alone (RUN_SERIAL).
# Test names start with "hil_" (ctest -R hil_).
#
# AddressSanitizer cannot run inside UML 6.1 (512 GiB of user address space; ASan's x86-64
# shadow needs 16 TiB): with EF_SANITIZE, binaries run in the guest are built by
# ef_hil_executable() without -fsanitize=address (UBSan kept), from sources, not ef_host.
set(EF_HIL_RUN ${CMAKE_CURRENT_SOURCE_DIR}/hil/uml_run.sh)

# add_executable for a binary that runs inside the guest: NAME SOURCES... ; links ef_host
# normally, or compiles the listed sources itself without ASan under EF_SANITIZE.
function(ef_hil_executable name)
  add_executable(${name} ${ARGN})
  target_include_directories(${name} PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}
    ${PROJECT_SOURCE_DIR}/host/include ${PROJECT_SOURCE_DIR}/firmware/include)
  target_compile_definitions(${name} PRIVATE _DEFAULT_SOURCE _GNU_SOURCE)
  if(EF_SANITIZE)
    target_compile_options(${name} PRIVATE -fno-sanitize=address)
    target_link_options(${name} PRIVATE -fno-sanitize=address)
  endif()
endfunction()

# SocketCAN transport (host/lib/can/ef_sockcan.c). test_sockcan (ef_host, sanitized like the
# rest) runs the parts that need no CAN on the build host; the guest runs the whole test.
add_executable(test_sockcan ${CMAKE_CURRENT_SOURCE_DIR}/can/test_sockcan.c)
target_include_directories(test_sockcan PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
target_link_libraries(test_sockcan PRIVATE ef_host)
add_test(NAME sockcan_offline
         COMMAND test_sockcan offline ${CMAKE_CURRENT_BINARY_DIR})
set_tests_properties(sockcan_offline PROPERTIES TIMEOUT 30)

if(EF_SANITIZE)
  # The guest binary is built without ASan from the sources it needs: the transports, the
  # pump and, for the pump's master and drive nodes, the whole firmware library.
  get_target_property(EF_HIL_FW_DIR ef_fw SOURCE_DIR)
  get_target_property(EF_HIL_FW_SRC ef_fw SOURCES)
  list(TRANSFORM EF_HIL_FW_SRC PREPEND "${EF_HIL_FW_DIR}/")
  set(EF_HIL_CAN_LIB ${PROJECT_SOURCE_DIR}/host/lib/can)
  ef_hil_executable(test_sockcan_uml ${CMAKE_CURRENT_SOURCE_DIR}/can/test_sockcan.c
    ${EF_HIL_CAN_LIB}/ef_sockcan.c ${EF_HIL_CAN_LIB}/ef_canif.c ${EF_HIL_CAN_LIB}/ef_canmem.c
    ${EF_HIL_CAN_LIB}/ef_canpump.c ${PROJECT_SOURCE_DIR}/host/lib/core/ef_host.c
    ${EF_HIL_FW_SRC})
  target_link_libraries(test_sockcan_uml PRIVATE m)
  set(EF_SOCKCAN_GUEST_BIN $<TARGET_FILE:test_sockcan_uml>)
  set(EF_SOCKCAN_DEPS test_sockcan_uml)
else()
  set(EF_SOCKCAN_GUEST_BIN $<TARGET_FILE:test_sockcan>)
endif()
add_test(NAME hil_sockcan
         COMMAND bash ${EF_HIL_RUN} ${CMAKE_CURRENT_SOURCE_DIR}/hil/sockcan.sh
                 ${CMAKE_CURRENT_BINARY_DIR}/hil_sockcan/verdict 120
                 ${EF_SOCKCAN_GUEST_BIN} ${CMAKE_CURRENT_BINARY_DIR}/hil_sockcan)
set_tests_properties(hil_sockcan PROPERTIES TIMEOUT 150 SKIP_RETURN_CODE 77 RESOURCE_LOCK uml
                     RUN_SERIAL ON)

# CAN streaming end to end (docs/can.md): three `evenfeed sim-drive can` drives and
# `evenfeed stream --can` on vcan0 in the guest, checked by test_can_hil (run in the guest).
# Not in sanitized builds: the evenfeed binary links ef_host with ASan, which cannot run in
# UML; the release build (also run by ./dev test and CI) runs them.
if(NOT EF_SANITIZE AND TARGET ef_tables_default)
  add_executable(test_can_hil ${CMAKE_CURRENT_SOURCE_DIR}/can/test_can_hil.c)
  target_include_directories(test_can_hil PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(test_can_hil PRIVATE ef_host ef_tables_default m)
  # hil_can_*: streaming and faults; hil_io_*: the machine I/O (docs/io.md) on a gpio-sim
  # chip the guest script makes; hil_gsusb_*: the same drives through a USB-CAN adapter
  # (gs_usb over libusb) that the part simulates on the guest's USB bus (dummy_hcd).
  foreach(part csp segment axes drop emcy heartbeat busoff boot start masterdeath
               io_estop io_start io_alarm io_pump io_hold io_hold_seg io_outputs io_modbus
               io_modbus_hold io_modbus_hold_direct io_gpioerr io_sto io_modbus_sto
               gsusb_csp gsusb_segment gsusb_unplug gsusb_bitrate gsusb_claimed gsusb_faults)
    if(part MATCHES "^(io|gsusb)_")
      set(name hil_${part})
    else()
      set(name hil_can_${part})
    endif()
    add_test(NAME ${name}
             COMMAND bash ${EF_HIL_RUN} ${CMAKE_CURRENT_SOURCE_DIR}/hil/can.sh
                     ${CMAKE_CURRENT_BINARY_DIR}/${name}/verdict 240
                     $<TARGET_FILE:test_can_hil> $<TARGET_FILE:evenfeed> ${PROJECT_SOURCE_DIR}
                     ${CMAKE_CURRENT_BINARY_DIR}/${name}/out ${part})
    # One guest at a time (RESOURCE_LOCK uml): two emulated kernels on a 2-core machine
    # starve each other. And nothing beside it (RUN_SERIAL): the checks are in drive time
    # and hold on a loaded host, but CI's 2 cores with ctest -j2 held a whole guest back
    # for over 2 s, which the drives' SYNC watchdog rightly takes for a dead master.
    set_tests_properties(${name} PROPERTIES TIMEOUT 280 SKIP_RETURN_CODE 77
                         RESOURCE_LOCK uml RUN_SERIAL ON)
  endforeach()
endif()

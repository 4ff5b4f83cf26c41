# SPDX-License-Identifier: Apache-2.0
# The simulated gs_usb adapter (`evenfeed sim-adapter gsusb`, host/lib/can/ef_gsusb_sim.c)
# against the kernel's own gs_usb driver, in User-Mode Linux (docs/can.md, docs/hil.md):
# tests/hil/gsusb.sh makes the adapter on dummy_hcd, lets gs_usb bind to it, and checks bit
# timing, RX, TX with its echo and the bridge to vcan0 with iproute2 and can-utils.
# Like the other HIL tests (can/hil.cmake): skipped (77) without the HIL kernel, one guest
# at a time (RESOURCE_LOCK uml), nothing beside it (RUN_SERIAL). Not in sanitized builds:
# the evenfeed binary links ef_host with ASan, which cannot run in UML.
if(NOT EF_SANITIZE)
  add_test(NAME hil_gsusb_kernel
           COMMAND bash ${EF_HIL_RUN} ${CMAKE_CURRENT_SOURCE_DIR}/hil/gsusb.sh
                   ${CMAKE_CURRENT_BINARY_DIR}/hil_gsusb_kernel/verdict 150
                   $<TARGET_FILE:evenfeed> ${CMAKE_CURRENT_BINARY_DIR}/hil_gsusb_kernel/out)
  set_tests_properties(hil_gsusb_kernel PROPERTIES TIMEOUT 180 SKIP_RETURN_CODE 77
                       RESOURCE_LOCK uml RUN_SERIAL ON)
endif()

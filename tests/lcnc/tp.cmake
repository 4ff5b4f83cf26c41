# SPDX-License-Identifier: Apache-2.0
# The LinuxCNC planner core (host/lib/lcnc/ef_tp.c) on recorded motmod call traces and
# synthetic sessions, in every build (ASan/UBSan in the test build); LinuxCNC not needed.
if(TARGET ef_tables_default)
  add_executable(test_tp ${CMAKE_CURRENT_LIST_DIR}/test_tp.c)
  target_link_libraries(test_tp PRIVATE ef_host ef_tables_default m)
  file(GLOB EF_TP_TRACES ${CMAKE_CURRENT_LIST_DIR}/traces/*.trace)
  add_test(NAME lcnc_tp COMMAND test_tp override pause abort stream dio arc aux mixed inhibit
                               auxrefused vlimit bad)
  add_test(NAME lcnc_tp_replay COMMAND test_tp replay ${EF_TP_TRACES})
  set_tests_properties(lcnc_tp lcnc_tp_replay PROPERTIES TIMEOUT 600)
endif()

# The module itself inside LinuxCNC's simulator (tp_sim.py): installs evenfeedtp.so into
# LinuxCNC's module directory (root, as in CI), runs the XYZ benchmark machine with it and
# with LinuxCNC's own planner, checks path, limits, end, feed override, pause and abort.
# Skipped (77) without LinuxCNC or without write access to its module directory.
if(TARGET evenfeedtp AND TARGET evenfeed)
  add_test(NAME lcnc_tp_sim
           COMMAND sh -c "command -v python3 >/dev/null 2>&1 || { echo 'lcnc_tp_sim: no python3 (skipped)'; exit 77; }; exec python3 \"$@\"" sh
                   ${CMAKE_CURRENT_LIST_DIR}/tp_sim.py
                   --evenfeed $<TARGET_FILE:evenfeed> --module $<TARGET_FILE:evenfeedtp>
                   --work ${CMAKE_CURRENT_BINARY_DIR}/lcnc-tp-sim)
  set_tests_properties(lcnc_tp_sim PROPERTIES SKIP_RETURN_CODE 77 RESOURCE_LOCK linuxcnc
                       TIMEOUT 900)
endif()

# SPDX-License-Identifier: Apache-2.0
# LinuxCNC side by side (tests/bench/lcnc, docs/benchmarks-linuxcnc.md): lcnc_smoke runs
# smoke.ngc through `evenfeed smooth` and through LinuxCNC's planner on the simulated
# benchmark machine and checks that both runs work, that both cycle times are positive and
# that both paths end at the same point. The figures themselves are the benchmark's
# (tests/bench/lcnc/run.sh), not a test. Skipped (77) where LinuxCNC (Debian 12:
# linuxcnc-uspace) or python3 is not installed; one LinuxCNC per machine (RESOURCE_LOCK).
if(TARGET evenfeed)
  add_test(NAME lcnc_smoke
           COMMAND sh -c "command -v python3 >/dev/null 2>&1 || { echo 'lcnc_smoke: no python3 (skipped)'; exit 77; }; exec python3 \"$@\"" sh
                   ${CMAKE_CURRENT_LIST_DIR}/compare.py --smoke --no-cache
                   --evenfeed $<TARGET_FILE:evenfeed>
                   --work ${CMAKE_CURRENT_BINARY_DIR}/lcnc-smoke
                   ${CMAKE_CURRENT_LIST_DIR}/smoke.ngc)
  # lcnc_run.sh's own limit (EF_LCNC_TIMEOUT) well inside ctest's, so that a stuck run is
  # stopped by the script, which stops every LinuxCNC process it started, not killed by
  # ctest with LinuxCNC left running.
  set_tests_properties(lcnc_smoke PROPERTIES SKIP_RETURN_CODE 77 RESOURCE_LOCK linuxcnc
                       ENVIRONMENT "EF_LCNC_TIMEOUT=240" TIMEOUT 420)
endif()

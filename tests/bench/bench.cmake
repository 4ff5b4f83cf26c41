# SPDX-License-Identifier: Apache-2.0
# Constant-time benchmark: instruction counts per ef_seg_g1_cubic / ef_seg_g2_quintic call
# under callgrind (tests/bench/ct_bench.sh). Not with sanitizers: their instrumentation
# adds data-dependent checks to the counted code, and valgrind cannot run ASan binaries.
if(NOT EF_SANITIZE)
  # The figures are defined at -O2 whatever the build type, so the bench links its own copy
  # of the firmware library built from ef_fw's sources with ef_fw's flags plus -O2 (later
  # on the command line than the build type's -O3/-Os, so it wins). -g only adds line
  # information for callgrind_annotate; it does not change the code.
  get_target_property(EF_BENCH_FW_DIR ef_fw SOURCE_DIR)
  get_target_property(EF_BENCH_FW_SRC ef_fw SOURCES)
  get_target_property(EF_BENCH_FW_OPT ef_fw COMPILE_OPTIONS)
  list(TRANSFORM EF_BENCH_FW_SRC PREPEND "${EF_BENCH_FW_DIR}/")
  add_library(ef_fw_bench STATIC EXCLUDE_FROM_ALL ${EF_BENCH_FW_SRC})
  target_include_directories(ef_fw_bench PUBLIC ${EF_BENCH_FW_DIR}/include)
  target_compile_options(ef_fw_bench PRIVATE ${EF_BENCH_FW_OPT} -O2 -g)

  add_executable(bench_ct bench/bench_ct.c)
  target_include_directories(bench_ct PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
  target_link_libraries(bench_ct PRIVATE ef_fw_bench m)
  # Synthetic tables of the default shapes (bench_ct.c); counts do not depend on the values
  # or node counts. ON measures the linked default tables instead (ef_fw_bench comes first
  # on the link line, so the tables' own ef_fw dependency adds no code).
  set(EF_BENCH_USE_DEFAULT_TABLES OFF)
  if(EF_BENCH_USE_DEFAULT_TABLES AND TARGET ef_tables_default)
    target_compile_definitions(bench_ct PRIVATE EF_BENCH_DEFAULT_TABLES)
    target_link_libraries(bench_ct PRIVATE ef_tables_default)
  endif()

  add_test(NAME fw_constant_time
           COMMAND sh ${CMAKE_CURRENT_SOURCE_DIR}/bench/ct_bench.sh $<TARGET_FILE:bench_ct>
                   2000 g1 g2 blend)
  set_tests_properties(fw_constant_time PROPERTIES SKIP_RETURN_CODE 77 TIMEOUT 300)

  # Smoothing benchmarks (tests/bench/run_all.sh, docs/benchmarks-smoothing.md), against the
  # default tables. bench_blends compares corner treatments with its own geometry (it needs
  # only ef_blend_corner); with EF_BENCH_SMOOTH it also runs the streaming smoother, and
  # bench_smooth (reader -> smoother -> interpolator throughput) and bench_ct_path (per-call
  # instruction counts of the per-move functions) are built. OFF leaves everything that needs
  # ef_smooth / ef_plan / ef_prim / ef_interp out.
  option(EF_BENCH_SMOOTH "Smoothing benchmarks that need the runtime smoother" ON)
  if(TARGET ef_tables_default)
    add_executable(bench_blends bench/bench_blends.c)
    target_include_directories(bench_blends PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
    target_link_libraries(bench_blends PRIVATE ef_fw ef_tables_default m)
    add_executable(gen_cam bench/gen_cam.c)
    target_link_libraries(gen_cam PRIVATE m)
    # The comparison must keep working: E, A and F within P, E and F G2, A not.
    add_test(NAME bench_blends_smoke COMMAND bench_blends --quick)
    set_tests_properties(bench_blends_smoke PROPERTIES PASS_REGULAR_EXPRESSION "smoke: OK")
    # The generated program must stay readable.
    add_test(NAME bench_gen_cam_smoke
             COMMAND sh -c "\"$1\" -n 3000 -o \"$3\" && \"$2\" gcode \"$3\" >/dev/null" sh
                     $<TARGET_FILE:gen_cam> $<TARGET_FILE:evenfeed>
                     ${CMAKE_CURRENT_BINARY_DIR}/gen_cam_smoke.ngc)
    if(EF_BENCH_SMOOTH)
      target_compile_definitions(bench_blends PRIVATE EF_BENCH_SMOOTH)
      add_executable(bench_smooth bench/bench_smooth.c)
      target_link_libraries(bench_smooth PRIVATE ef_host ef_tables_default ef_fw m)
      add_executable(bench_ct_path bench/bench_ct.c)
      target_include_directories(bench_ct_path PRIVATE ${CMAKE_CURRENT_SOURCE_DIR})
      target_compile_definitions(bench_ct_path PRIVATE EF_BENCH_PATH EF_BENCH_DEFAULT_TABLES)
      target_link_libraries(bench_ct_path PRIVATE ef_fw_bench ef_tables_default m)
    endif()
  endif()
endif()

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
endif()

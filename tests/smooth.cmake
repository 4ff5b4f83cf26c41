# The streaming smoother (firmware ef_smooth) end to end against the default tables:
# invariants of every run, deviation measured independently, vertex rules, bad input.
if(TARGET ef_tables_default)
  add_executable(test_smooth test_smooth.c)
  target_link_libraries(test_smooth PRIVATE ef_fw ef_tables_default m)
  add_test(NAME fw_smooth COMMAND test_smooth)
  set_tests_properties(fw_smooth PROPERTIES TIMEOUT 600)
endif()

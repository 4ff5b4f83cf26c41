# SPDX-License-Identifier: Apache-2.0
# Self-test of the test harness (tests/ef_test.h): a test binary cannot pass having checked
# nothing. The part runner fails on an unknown part name, on arguments to a part that takes
# none, on a part that ran no check and on a failed check; ef_test_summary() fails when no
# check ran. The fuzz replay driver (tests/fuzz/replay.h) fails when it replayed nothing.
add_executable(test_harness ${CMAKE_CURRENT_SOURCE_DIR}/core/test_harness.c)
target_link_libraries(test_harness PRIVATE m)

# Runs that pass: one part, a part of two functions with another after it, a part with its
# arguments.
add_test(NAME harness_one COMMAND test_harness one)
add_test(NAME harness_several COMMAND test_harness two one)
add_test(NAME harness_args COMMAND test_harness args x y)
# Runs that must fail.
foreach(t unknown:nosuch empty:none failed:bad extra:one:surplus args_missing:args
          all:all summary_empty:--summary-only)
  string(REPLACE ":" ";" t "${t}")
  list(POP_FRONT t name)
  add_test(NAME harness_fails_${name} COMMAND test_harness ${t})
  set_tests_properties(harness_fails_${name} PROPERTIES WILL_FAIL TRUE)
endforeach()
# Running all parts fails too (one of them checks nothing), without naming any.
add_test(NAME harness_fails_noargs COMMAND test_harness)
set_tests_properties(harness_fails_noargs PROPERTIES WILL_FAIL TRUE)
# What the runner says: the unknown name and the parts there are, and exit status 1; an empty
# part by name; and the skip status.
add_test(NAME harness_unknown_message
         COMMAND sh -c "\"$1\" nosuch 2>&1; echo \"exit $?\"" sh $<TARGET_FILE:test_harness>)
set_tests_properties(harness_unknown_message PROPERTIES PASS_REGULAR_EXPRESSION
  "unknown part 'nosuch'\n[^\n]*known parts \\(none: all\\): one, two, none, bad, skip, args X Y\n0 passed, 0 failed\nexit 1\n")
add_test(NAME harness_empty_message
         COMMAND sh -c "\"$1\" one none 2>&1; echo \"exit $?\"" sh $<TARGET_FILE:test_harness>)
set_tests_properties(harness_empty_message PROPERTIES PASS_REGULAR_EXPRESSION
  "part none ran no checks\n.*1 passed, 0 failed\nexit 1\n")
add_test(NAME harness_skip
         COMMAND sh -c "\"$1\" skip; test $? -eq 77" sh $<TARGET_FILE:test_harness>)

# The fuzz replay driver (tfile_fuzz_replay, tests/table/tfile.cmake) on a missing corpus,
# an empty one, and an empty one named after a full one: each directory must give inputs.
set(EF_HARNESS_EMPTY_DIR ${CMAKE_CURRENT_BINARY_DIR}/harness_empty_corpus)
file(MAKE_DIRECTORY ${EF_HARNESS_EMPTY_DIR})
add_test(NAME harness_replay_fails_missing
         COMMAND tfile_fuzz_replay ${CMAKE_CURRENT_BINARY_DIR}/harness_no_such_corpus)
add_test(NAME harness_replay_fails_empty COMMAND tfile_fuzz_replay ${EF_HARNESS_EMPTY_DIR})
add_test(NAME harness_replay_fails_one_empty
         COMMAND tfile_fuzz_replay ${CMAKE_CURRENT_SOURCE_DIR}/fuzz/corpus ${EF_HARNESS_EMPTY_DIR})
add_test(NAME harness_replay_fails_noargs COMMAND tfile_fuzz_replay)
set_tests_properties(harness_replay_fails_missing harness_replay_fails_empty
                     harness_replay_fails_one_empty harness_replay_fails_noargs
                     PROPERTIES WILL_FAIL TRUE)

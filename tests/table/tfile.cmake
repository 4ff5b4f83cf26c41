# SPDX-License-Identifier: Apache-2.0
# Table file format: parser, host file API, C emitter, fuzz corpus replay and the optional
# libFuzzer target (docs/table-format.md). Test names start with "tfile" (ctest -R tfile).
set(EF_TFILE_DIR ${CMAKE_CURRENT_SOURCE_DIR})

add_executable(test_tfile ${CMAKE_CURRENT_SOURCE_DIR}/table/test_tfile.c)
target_include_directories(test_tfile PRIVATE ${EF_TFILE_DIR})
target_link_libraries(test_tfile PRIVATE ef_host m)
add_test(NAME tfile_unit COMMAND test_tfile)
set_tests_properties(tfile_unit PROPERTIES ENVIRONMENT "TMPDIR=${CMAKE_CURRENT_BINARY_DIR}")

# Emitter round trip: test_tfile writes two tables and their C sources at build time; a
# second executable compiles those sources (with the firmware's own warning flags, such as
# -Wdouble-promotion) and compares them with the .eft files bit for bit.
set(EF_TFILE_GEN ${CMAKE_CURRENT_BINARY_DIR}/tfile_emitted)
set(EF_TFILE_GEN_C ${EF_TFILE_GEN}/g1.c ${EF_TFILE_GEN}/g2.c)
add_custom_command(
  OUTPUT ${EF_TFILE_GEN_C} ${EF_TFILE_GEN}/g1.eft ${EF_TFILE_GEN}/g2.eft
  COMMAND ${CMAKE_COMMAND} -E make_directory ${EF_TFILE_GEN}
  COMMAND test_tfile --emit g1 ef_emitted_g1 ${EF_TFILE_GEN}/g1.c ${EF_TFILE_GEN}/g1.eft
  COMMAND test_tfile --emit g2 ef_emitted_g2 ${EF_TFILE_GEN}/g2.c ${EF_TFILE_GEN}/g2.eft
  DEPENDS test_tfile
  COMMENT "Emitting C sources of the emitter-test tables"
  VERBATIM)
get_target_property(EF_TFILE_FW_OPT ef_fw COMPILE_OPTIONS)
set_source_files_properties(${EF_TFILE_GEN_C} PROPERTIES COMPILE_OPTIONS "${EF_TFILE_FW_OPT}")
add_executable(test_tfile_emitted ${CMAKE_CURRENT_SOURCE_DIR}/table/test_tfile.c ${EF_TFILE_GEN_C})
target_compile_definitions(test_tfile_emitted PRIVATE EF_TFILE_EMITTED)
target_include_directories(test_tfile_emitted PRIVATE ${EF_TFILE_DIR})
target_link_libraries(test_tfile_emitted PRIVATE ef_host m)
add_test(NAME tfile_emitted
         COMMAND test_tfile_emitted ${EF_TFILE_GEN}/g1.eft ${EF_TFILE_GEN}/g2.eft)

# Fuzz seed corpus: generator, a check that the checked-in corpus is current, and a replay
# of every seed through the fuzz entry point without libFuzzer (runs under ASan/UBSan in
# the sanitizer build). Regenerate: tfile_make_corpus tests/fuzz/corpus
add_executable(tfile_make_corpus ${EF_TFILE_DIR}/fuzz/make_corpus.c)
target_link_libraries(tfile_make_corpus PRIVATE ef_host)
add_test(NAME tfile_corpus_current
         COMMAND tfile_make_corpus --check ${EF_TFILE_DIR}/fuzz/corpus)

add_executable(tfile_fuzz_replay ${EF_TFILE_DIR}/fuzz/replay_main.c
                                 ${EF_TFILE_DIR}/fuzz/fuzz_table_parse.c)
target_link_libraries(tfile_fuzz_replay PRIVATE ef_fw)
add_test(NAME tfile_fuzz_replay COMMAND tfile_fuzz_replay ${EF_TFILE_DIR}/fuzz/corpus)

# libFuzzer target (tests/fuzz/run.sh drives it). The firmware is rebuilt from ef_fw's own
# sources and flags with coverage and sanitizer instrumentation, whatever EF_SANITIZE says:
# an uninstrumented parser would give the fuzzer neither coverage nor out-of-bounds reports.
if(EF_FUZZ)
  if(NOT CMAKE_C_COMPILER_ID MATCHES "Clang")
    message(FATAL_ERROR "EF_FUZZ=ON needs clang (configure with CC=clang)")
  endif()
  set(EF_FUZZ_SAN -fsanitize=address,undefined -fno-sanitize-recover=all
      -fno-omit-frame-pointer)
  get_target_property(EF_FUZZ_FW_DIR ef_fw SOURCE_DIR)
  get_target_property(EF_FUZZ_FW_SRC ef_fw SOURCES)
  list(TRANSFORM EF_FUZZ_FW_SRC PREPEND "${EF_FUZZ_FW_DIR}/")
  add_library(ef_fw_fuzz STATIC ${EF_FUZZ_FW_SRC})
  target_include_directories(ef_fw_fuzz PUBLIC ${EF_FUZZ_FW_DIR}/include)
  target_compile_options(ef_fw_fuzz PRIVATE ${EF_TFILE_FW_OPT} -fsanitize=fuzzer-no-link
                         ${EF_FUZZ_SAN})

  add_executable(fuzz_table_parse ${EF_TFILE_DIR}/fuzz/fuzz_table_parse.c)
  target_compile_options(fuzz_table_parse PRIVATE -fsanitize=fuzzer ${EF_FUZZ_SAN})
  target_link_options(fuzz_table_parse PRIVATE -fsanitize=fuzzer ${EF_FUZZ_SAN})
  target_link_libraries(fuzz_table_parse PRIVATE ef_fw_fuzz)
endif()

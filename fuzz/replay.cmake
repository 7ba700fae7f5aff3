# Defines postproc_fuzz_replay: fuzz_reader.cpp's LLVMFuzzerTestOneInput driven by a plain main(),
# built with whatever compiler the project uses, so the test suite can replay fuzz/corpus and
# fuzz/crashes without clang or libFuzzer. Include it from any CMakeLists.txt after postproc::core
# exists; including it twice is harmless.
#
#   include(${PROJECT_SOURCE_DIR}/fuzz/replay.cmake)
#   postproc_add_fuzz_replay_test(fuzz_replay)   # optional: registers the ctest

set(POSTPROC_FUZZ_DIR "${CMAKE_CURRENT_LIST_DIR}" CACHE INTERNAL "fuzz/ directory (corpus, crashes)")

# Dialects with a pipeline target (fuzz_resolve.cpp): DialectId enumerators.
set(POSTPROC_FUZZ_DIALECTS fanuc siemens linuxcnc heidenhain_iso CACHE INTERNAL "dialects of the resolve fuzz targets")

# Data-file targets (fuzz_<kind>.cpp), each with its own seed corpus fuzz/corpus_<kind>/ and its
# saved crashes in fuzz/crashes_<kind>/.
set(POSTPROC_FUZZ_DATA_KINDS machine measurements CACHE INTERNAL "data-file fuzz targets")

if(NOT TARGET postproc_fuzz_replay)
  add_executable(postproc_fuzz_replay
    "${POSTPROC_FUZZ_DIR}/replay_main.cpp"
    "${POSTPROC_FUZZ_DIR}/fuzz_reader.cpp")
  target_link_libraries(postproc_fuzz_replay PRIVATE postproc::core)
  if(TARGET postproc_warnings)
    target_link_libraries(postproc_fuzz_replay PRIVATE postproc_warnings)
  endif()
  # The same replayer around each pipeline target: postproc_fuzz_replay_resolve_<dialect>.
  foreach(_dialect IN LISTS POSTPROC_FUZZ_DIALECTS)
    add_executable(postproc_fuzz_replay_resolve_${_dialect}
      "${POSTPROC_FUZZ_DIR}/replay_main.cpp"
      "${POSTPROC_FUZZ_DIR}/fuzz_resolve.cpp")
    target_compile_definitions(postproc_fuzz_replay_resolve_${_dialect} PRIVATE POSTPROC_FUZZ_DIALECT=${_dialect})
    target_link_libraries(postproc_fuzz_replay_resolve_${_dialect} PRIVATE postproc::core)
    if(TARGET postproc_warnings)
      target_link_libraries(postproc_fuzz_replay_resolve_${_dialect} PRIVATE postproc_warnings)
    endif()
  endforeach()
  # The replayers of the data-file targets: postproc_fuzz_replay_<kind>.
  foreach(_kind IN LISTS POSTPROC_FUZZ_DATA_KINDS)
    add_executable(postproc_fuzz_replay_${_kind} "${POSTPROC_FUZZ_DIR}/replay_main.cpp" "${POSTPROC_FUZZ_DIR}/fuzz_${_kind}.cpp")
    target_compile_definitions(postproc_fuzz_replay_${_kind} PRIVATE POSTPROC_SAMPLES_DIR="${PROJECT_SOURCE_DIR}/samples")
    target_link_libraries(postproc_fuzz_replay_${_kind} PRIVATE postproc::core)
    if(TARGET postproc_warnings)
      target_link_libraries(postproc_fuzz_replay_${_kind} PRIVATE postproc_warnings)
    endif()
  endforeach()
endif()

# Registers a test NAME that replays the seed corpus and every saved crash input through the
# reader target, and NAME_resolve_<dialect> through each pipeline target (every input through
# every target: an input found by one must pass all).
function(postproc_add_fuzz_replay_test name)
  add_test(NAME ${name}
           COMMAND postproc_fuzz_replay "${POSTPROC_FUZZ_DIR}/corpus" "${POSTPROC_FUZZ_DIR}/crashes")
  foreach(_dialect IN LISTS POSTPROC_FUZZ_DIALECTS)
    add_test(NAME ${name}_resolve_${_dialect}
             COMMAND postproc_fuzz_replay_resolve_${_dialect} "${POSTPROC_FUZZ_DIR}/corpus" "${POSTPROC_FUZZ_DIR}/crashes")
  endforeach()
  foreach(_kind IN LISTS POSTPROC_FUZZ_DATA_KINDS)
    add_test(NAME ${name}_${_kind}
             COMMAND postproc_fuzz_replay_${_kind} "${POSTPROC_FUZZ_DIR}/corpus_${_kind}" "${POSTPROC_FUZZ_DIR}/crashes_${_kind}")
  endforeach()
endfunction()

# Defines postproc_fuzz_replay: fuzz_reader.cpp's LLVMFuzzerTestOneInput driven by a plain main(),
# built with whatever compiler the project uses, so the test suite can replay fuzz/corpus and
# fuzz/crashes without clang or libFuzzer. Include it from any CMakeLists.txt after postproc::core
# exists; including it twice is harmless.
#
#   include(${PROJECT_SOURCE_DIR}/fuzz/replay.cmake)
#   postproc_add_fuzz_replay_test(fuzz_replay)   # optional: registers the ctest

set(POSTPROC_FUZZ_DIR "${CMAKE_CURRENT_LIST_DIR}" CACHE INTERNAL "fuzz/ directory (corpus, crashes)")

if(NOT TARGET postproc_fuzz_replay)
  add_executable(postproc_fuzz_replay
    "${POSTPROC_FUZZ_DIR}/replay_main.cpp"
    "${POSTPROC_FUZZ_DIR}/fuzz_reader.cpp")
  target_link_libraries(postproc_fuzz_replay PRIVATE postproc::core)
  if(TARGET postproc_warnings)
    target_link_libraries(postproc_fuzz_replay PRIVATE postproc_warnings)
  endif()
endif()

# Registers a test NAME that replays the seed corpus and every saved crash input.
function(postproc_add_fuzz_replay_test name)
  add_test(NAME ${name}
           COMMAND postproc_fuzz_replay "${POSTPROC_FUZZ_DIR}/corpus" "${POSTPROC_FUZZ_DIR}/crashes")
endfunction()

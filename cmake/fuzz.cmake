# SMSEG_FUZZ=ON: libFuzzer executables, one per reader of a user's file (fuzz/, docs/reliability.md).
# The project's libraries are compiled with coverage instrumentation and AddressSanitizer +
# UndefinedBehaviorSanitizer so that the fuzzers reach into our readers and any memory or UB error
# stops the run; the fuzzers link libFuzzer's main. Build them all with the target smseg_fuzzers.
option(SMSEG_FUZZ "Build the libFuzzer fuzzers of the file readers (clang only)" OFF)

if(SMSEG_FUZZ)
  if(NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
    message(FATAL_ERROR "SMSEG_FUZZ=ON needs clang (libFuzzer); this build uses ${CMAKE_CXX_COMPILER_ID} "
                        "${CMAKE_CXX_COMPILER}. Configure a separate build with -DCMAKE_CXX_COMPILER=clang++.")
  endif()
  # Everything compiled from here on (our libraries, and the tools and tests if they are built)
  # carries the instrumentation; UB reports abort instead of printing and going on.
  add_compile_options(-fsanitize=fuzzer-no-link,address,undefined -fno-omit-frame-pointer
                      -fno-sanitize-recover=undefined)
  add_link_options(-fsanitize=address,undefined)
  add_subdirectory(${CMAKE_CURRENT_LIST_DIR}/../fuzz ${CMAKE_BINARY_DIR}/fuzz)
endif()

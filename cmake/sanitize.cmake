# -DSMSEG_SANITIZE=address,undefined builds everything (our modules, tools, tests, benchmarks and the
# Python module) with those sanitizers (docs/reliability.md, "Sanitizer builds"). UBSan findings are
# fatal (-fno-sanitize-recover), so a test that triggers one fails instead of printing and passing.
# tests/run-sanitized.sh configures such a build and runs the suite under it; .ci/run calls it.
set(SMSEG_SANITIZE "" CACHE STRING
    "Sanitizers for every target, comma-separated (address,undefined; empty: none)")

if(SMSEG_SANITIZE)
  string(REPLACE "," ";" smseg_sanitizers "${SMSEG_SANITIZE}")
  foreach(s IN LISTS smseg_sanitizers)
    if(NOT s MATCHES "^(address|undefined|leak|thread)$")
      message(FATAL_ERROR "SMSEG_SANITIZE: unknown sanitizer '${s}' (address, undefined, leak or thread)")
    endif()
  endforeach()
  if("thread" IN_LIST smseg_sanitizers AND "address" IN_LIST smseg_sanitizers)
    message(FATAL_ERROR "SMSEG_SANITIZE: thread and address cannot be combined")
  endif()
  add_compile_options(-fsanitize=${SMSEG_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  # GCC's flow analysis sees the sanitizers' instrumentation and warns of "maybe uninitialized" values
  # inside libstdc++ (std::regex's std::function states) that the normal build, which keeps the warning
  # as an error, does not; finding real uninitialized reads is the sanitizers' job here.
  if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU")
    add_compile_options(-Wno-maybe-uninitialized)
  endif()
  add_link_options(-fsanitize=${SMSEG_SANITIZE})
endif()

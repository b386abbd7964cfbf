# Flags of the hardening builds (docs/testing.md). Sanitizers only see code they instrument, so
# here, unlike elsewhere, the flags are directory-wide: every library and test gets them.
if(WM_FUZZ AND NOT CMAKE_CXX_COMPILER_ID STREQUAL "Clang")
  message(FATAL_ERROR "WM_FUZZ needs clang (libFuzzer): -DCMAKE_CXX_COMPILER=clang++")
endif()
if(WM_SANITIZE OR WM_FUZZ)
  # A UBSan report must fail the test or stop the fuzzer, not scroll past.
  # GCC's -fsanitize=undefined leaves out float-cast-overflow (1e120 -> int), which clang's has.
  set(WM_SANITIZER_FLAGS -fsanitize=address,undefined -fno-sanitize-recover=all
                         -fno-omit-frame-pointer
                         $<$<CXX_COMPILER_ID:GNU>:-fsanitize=float-cast-overflow>)
  add_compile_options(${WM_SANITIZER_FLAGS}
    # GCC 12 under ASan gives false maybe-uninitialized warnings inside <functional> / <regex>.
    $<$<CXX_COMPILER_ID:GNU>:-Wno-maybe-uninitialized>)
  add_link_options(${WM_SANITIZER_FLAGS})
  # ASan cannot see a read past the end of an mmap; MappedFile reads into the heap instead.
  add_compile_definitions(WM_MAPPED_FILE_ON_HEAP=1)
endif()
if(WM_FUZZ)
  # Coverage feedback from the libraries too; the fuzz executables add -fsanitize=fuzzer.
  add_compile_options(-fsanitize=fuzzer-no-link)
endif()

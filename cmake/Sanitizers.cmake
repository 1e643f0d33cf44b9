# OCCMAP_SANITIZE=address,undefined or thread: the whole build (project code) is instrumented.
if(OCCMAP_SANITIZE)
  add_compile_options(-fsanitize=${OCCMAP_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${OCCMAP_SANITIZE})
  # -O1: the sanitizers' own advice (fast enough to run, close enough to the source to report),
  # and a third less compile time than -O2 for CI's second and third builds.
  add_compile_options(-O1)
  # UBSan's per-access checks are left to the fuzzers (scripts/fuzz keeps all of UBSan on all of
  # occmap's code): under ASan a null dereference is reported anyway, as a SEGV with its stack;
  # x86-64 loads unaligned data and occmap reads unaligned bytes with memcpy; vptr wants every
  # polymorphic object checked at every call. The three cost a quarter of the ASan tree's compile
  # time (transport's unity file: 21.0 s of CPU with them, 16.2 s without, 12.5 s with ASan alone)
  # and checks in every hot loop of the tests that run under it.
  if(OCCMAP_SANITIZE MATCHES "undefined")
    add_compile_options(-fno-sanitize=null,alignment,vptr)
  endif()
endif()

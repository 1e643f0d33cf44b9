// Linked, in the plain build, into each test that CMake declares single-threaded
// (occmap_add_test(... SINGLE_THREADED)). ThreadSanitizer finds races between threads, so
// ./scripts/test runs those tests under ASan + UBSan but not under TSan, where they would take
// minutes to check nothing. This keeps the declaration true: the executable's own pthread_create
// comes before the C library's, for its code and for every library it calls (std::thread, OpenCV's
// thread pool), and a thread started by such a test ends it with what to do about it.
// The sanitizer builds leave it out: their runtimes intercept pthread_create themselves.
#include <cstdio>
#include <cstdlib>

#include <pthread.h>

extern "C" int pthread_create(pthread_t* /*thread*/, const pthread_attr_t* /*attributes*/,
                              void* (* /*start*/)(void*), void* /*argument*/) noexcept {
  std::fputs(
      "this test is declared SINGLE_THREADED in tests/CMakeLists.txt (so ThreadSanitizer skips "
      "it), but it started a thread: remove SINGLE_THREADED from its occmap_add_test\n",
      stderr);
  std::abort();
}

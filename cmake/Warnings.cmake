# Project code builds clean with a strict warning set; OCCMAP_WERROR makes that a rule (CI keeps it on).
# No -Wnull-dereference: with GCC 12 it fires inside libstdc++'s string moves (seen through CLI11).
add_library(occmap_warnings INTERFACE)
target_compile_options(occmap_warnings INTERFACE
  -Wall -Wextra -Wpedantic -Wshadow -Wnon-virtual-dtor -Wold-style-cast -Wcast-align
  -Woverloaded-virtual -Wconversion -Wdouble-promotion -Wformat=2 -Wimplicit-fallthrough)
# GCC 12 at -O3 (Release) reports std::string's own inserts as overlapping memcpy: a known false
# -Wrestrict in libstdc++ (GCC bug 105651), fixed in GCC 13. Off for that compiler only.
if(CMAKE_CXX_COMPILER_ID STREQUAL "GNU" AND CMAKE_CXX_COMPILER_VERSION VERSION_LESS 13)
  target_compile_options(occmap_warnings INTERFACE -Wno-restrict)
endif()
if(OCCMAP_WERROR)
  target_compile_options(occmap_warnings INTERFACE -Werror)
endif()

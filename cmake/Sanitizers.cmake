# OCCMAP_SANITIZE=address,undefined or thread: the whole build (project code) is instrumented.
if(OCCMAP_SANITIZE)
  add_compile_options(-fsanitize=${OCCMAP_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${OCCMAP_SANITIZE})
  # -O1: the sanitizers' own advice (fast enough to run, close enough to the source to report),
  # and a third less compile time than -O2 for CI's second and third builds.
  add_compile_options(-O1)
endif()

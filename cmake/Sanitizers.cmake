# OCCMAP_SANITIZE=address,undefined or thread: the whole build (project code) is instrumented.
if(OCCMAP_SANITIZE)
  add_compile_options(-fsanitize=${OCCMAP_SANITIZE} -fno-omit-frame-pointer -fno-sanitize-recover=all)
  add_link_options(-fsanitize=${OCCMAP_SANITIZE})
endif()

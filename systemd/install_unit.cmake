# Part of `cmake --install` (see CMakeLists.txt): fills in the unit's paths from the prefix of this
# installation, CMAKE_INSTALL_PREFIX as `--prefix` set it, and installs it. file(INSTALL) adds
# DESTDIR to where the file goes (never to the paths inside it, which name the running system) and
# records the file in install_manifest.txt, as install(FILES) would.
#
# In: OCCMAP_UNIT_TEMPLATE, OCCMAP_UNIT_SCRATCH (where the filled-in unit is written first), and
# OCCMAP_UNIT_DIR, OCCMAP_BINDIR, OCCMAP_DOCDIR, each relative to the prefix or absolute.

function(occmap_under_prefix out dir)
  if(IS_ABSOLUTE "${dir}")
    set(${out} "${dir}" PARENT_SCOPE)
  else()
    set(${out} "${CMAKE_INSTALL_PREFIX}/${dir}" PARENT_SCOPE)
  endif()
endfunction()

occmap_under_prefix(CMAKE_INSTALL_FULL_BINDIR "${OCCMAP_BINDIR}")
occmap_under_prefix(CMAKE_INSTALL_FULL_DOCDIR "${OCCMAP_DOCDIR}")
occmap_under_prefix(occmap_unit_destination "${OCCMAP_UNIT_DIR}")
configure_file("${OCCMAP_UNIT_TEMPLATE}" "${OCCMAP_UNIT_SCRATCH}" @ONLY)
file(INSTALL DESTINATION "${occmap_unit_destination}" TYPE FILE FILES "${OCCMAP_UNIT_SCRATCH}")

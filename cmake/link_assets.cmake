# cmake -DFROM=<source assets> -DTO=<folder beside the binary> -P link_assets.cmake
# Makes TO a symbolic link to FROM, so that the build tree's command line finds the source tree's assets
# the way an installed one finds <prefix>/share/smoketrace (apps/cli/assets.hpp); a copy where the file
# system has no symbolic links. Run after every link of the command line (CMakeLists.txt).
if(NOT FROM OR NOT TO)
  message(FATAL_ERROR "link_assets.cmake: give -DFROM=<assets folder> -DTO=<link to make>")
endif()
if(IS_SYMLINK "${TO}")
  file(READ_SYMLINK "${TO}" current)
  if(current STREQUAL FROM)
    return()
  endif()
  file(REMOVE "${TO}")
endif()
if(NOT EXISTS "${TO}")
  file(CREATE_LINK "${FROM}" "${TO}" SYMBOLIC RESULT result)
  if(result STREQUAL "0")
    return()
  endif()
endif()
# No link: copy (over an earlier copy; nothing in it is removed).
file(COPY "${FROM}/" DESTINATION "${TO}")

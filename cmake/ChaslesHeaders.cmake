# chasles_install_headers(<header>...)
#
# Installs headers of the current source folder to include/chasles/<its path in the repository>/,
# with their include lines rewritten for that tree. In the repository every file includes another
# by its path from the repository's root ("core/lie/so3.hpp"), so that a reader or a tool without
# a build follows an include to its file; users include the installed headers as
# <chasles/core/lie/so3.hpp>, and the installed headers include each other the same way. Only the
# project's own folders are rewritten; generated and third-party headers are left as they are.
function(chasles_install_headers)
  file(RELATIVE_PATH folder ${PROJECT_SOURCE_DIR} ${CMAKE_CURRENT_SOURCE_DIR})
  foreach(header IN LISTS ARGN)
    set(source ${CMAKE_CURRENT_SOURCE_DIR}/${header})
    if(NOT EXISTS ${source})
      message(FATAL_ERROR "chasles_install_headers: ${source} does not exist")
    endif()
    set(destination "${CMAKE_INSTALL_INCLUDEDIR}/chasles/${folder}/${header}")
    install(CODE "
      set(target \"\$ENV{DESTDIR}\${CMAKE_INSTALL_PREFIX}/${destination}\")
      message(STATUS \"Installing: \${target}\")
      file(READ \"${source}\" text)
      string(REGEX REPLACE \"#include \\\"(core|controller|lcmtypes)/\" \"#include \\\"chasles/\\\\1/\" text \"\${text}\")
      file(WRITE \"\${target}\" \"\${text}\")")
  endforeach()
endfunction()

# Bakes the git revision of the source tree into the build at configure time, so that nothing
# reads git at run time (an installed rosguard has no source tree to ask).
#
# Sets ROSGUARD_GIT_REVISION: `git rev-parse --short=12 HEAD`, with "-dirty" when tracked files
# differ from HEAD, "unknown" outside a git checkout (e.g. a release tarball) or without git.
# A commit or checkout re-runs the configure step (its reflog is a configure dependency), so
# the revision follows HEAD; a later edit alone shows as "-dirty" from the next configure on.
find_package(Git QUIET)
set(ROSGUARD_GIT_REVISION "unknown")
if(GIT_FOUND)
  # Only this project's own checkout counts, not an enclosing repository that a tarball was
  # unpacked into.
  execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse --show-toplevel
                  WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                  OUTPUT_VARIABLE _top OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse --short=12 HEAD
                  WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                  OUTPUT_VARIABLE _rev OUTPUT_STRIP_TRAILING_WHITESPACE
                  RESULT_VARIABLE _rev_status ERROR_QUIET)
  file(REAL_PATH "${PROJECT_SOURCE_DIR}" _src)
  if(_top)
    file(REAL_PATH "${_top}" _top)
  endif()
  if(_rev_status EQUAL 0 AND _rev AND _top STREQUAL _src)
    set(ROSGUARD_GIT_REVISION "${_rev}")
    execute_process(COMMAND ${GIT_EXECUTABLE} status --porcelain --untracked-files=no
                    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                    OUTPUT_VARIABLE _changes ERROR_QUIET)
    if(_changes)
      string(APPEND ROSGUARD_GIT_REVISION "-dirty")
    endif()
    execute_process(COMMAND ${GIT_EXECUTABLE} rev-parse --path-format=absolute --git-path logs/HEAD
                    WORKING_DIRECTORY ${PROJECT_SOURCE_DIR}
                    OUTPUT_VARIABLE _reflog OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(_reflog AND EXISTS "${_reflog}")
      set_property(DIRECTORY ${PROJECT_SOURCE_DIR} APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS
                   "${_reflog}")
    endif()
  endif()
endif()
message(STATUS "rosguard ${PROJECT_VERSION}, git ${ROSGUARD_GIT_REVISION}")

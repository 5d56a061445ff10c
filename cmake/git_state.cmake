# Run at every build (cmake -P): writes the commit the binary is built from into a header that
# changes only when the commit or the tree's cleanliness does, so a run records what it measured.
#   -DSOURCE=<repository> -DOUTPUT=<header>
# "<short hash>" for a clean tree, "<short hash>-dirty" when tracked files differ from the commit,
# "" when SOURCE is not the top of a git checkout (a source tarball, even one unpacked inside
# another repository) or without git.
# A script run by cmake -P starts with no policies set: the project's, so that the escaped quotes
# below read without CMP0053's warning on every build.
cmake_minimum_required(VERSION 3.20)
set(commit "")
find_package(Git QUIET)
if(GIT_FOUND)
  execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE}" rev-parse --show-toplevel
                  OUTPUT_VARIABLE top RESULT_VARIABLE failed
                  OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  get_filename_component(source "${SOURCE}" REALPATH)
  if(NOT failed)
    get_filename_component(top "${top}" REALPATH)
  endif()
  if(NOT failed AND top STREQUAL source)
    execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE}" rev-parse --short=12 HEAD
                    OUTPUT_VARIABLE commit RESULT_VARIABLE failed
                    OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
    if(failed)
      set(commit "")
    else()
      # Tracked files only (the build tree and caches are ignored, untracked notes change no
      # code); without optional locks, so that a build never holds the index a commit needs.
      execute_process(COMMAND "${GIT_EXECUTABLE}" --no-optional-locks -C "${SOURCE}" status
                              --porcelain --untracked-files=no
                      OUTPUT_VARIABLE changes RESULT_VARIABLE failed ERROR_QUIET)
      if(NOT failed AND NOT changes STREQUAL "")
        string(APPEND commit "-dirty")
      endif()
    endif()
  endif()
endif()
# configure_file writes only when the text changes: an unchanged commit recompiles nothing.
set(ARENA_GIT_COMMIT "${commit}")
file(WRITE "${OUTPUT}.in" "// Generated at build time by cmake/git_state.cmake: never edit, never commit.\n"
                          "#pragma once\n#define ARENA_GIT_COMMIT \"@ARENA_GIT_COMMIT@\"\n")
configure_file("${OUTPUT}.in" "${OUTPUT}" @ONLY)
file(REMOVE "${OUTPUT}.in")

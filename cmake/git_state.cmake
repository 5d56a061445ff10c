# Run at every build (cmake -P): writes the commit the binary is built from into a header that
# changes only when the commit or the tree's cleanliness does, so a run records what it measured.
#   -DSOURCE=<repository> -DOUTPUT=<header>
# "<short hash>" for a clean tree, "<short hash>-dirty" when tracked files differ from the commit,
# "" outside a git checkout (a source tarball) or without git.
set(commit "")
find_package(Git QUIET)
if(GIT_FOUND)
  execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE}" rev-parse --short=12 HEAD
                  OUTPUT_VARIABLE commit RESULT_VARIABLE failed
                  OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET)
  if(failed)
    set(commit "")
  else()
    # Tracked files only: the build tree and caches are ignored, untracked notes change no code.
    execute_process(COMMAND "${GIT_EXECUTABLE}" -C "${SOURCE}" status --porcelain --untracked-files=no
                    OUTPUT_VARIABLE changes RESULT_VARIABLE failed ERROR_QUIET)
    if(NOT failed AND NOT changes STREQUAL "")
      string(APPEND commit "-dirty")
    endif()
  endif()
endif()
file(WRITE "${OUTPUT}.new" "// Generated at build time by cmake/git_state.cmake: never edit, never commit.\n"
                           "#pragma once\n#define ARENA_GIT_COMMIT \"${commit}\"\n")
file(COPY_FILE "${OUTPUT}.new" "${OUTPUT}" ONLY_IF_DIFFERENT)
file(REMOVE "${OUTPUT}.new")

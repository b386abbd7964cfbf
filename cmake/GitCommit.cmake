# Regenerates git_commit.cc on every build (copied only when the commit changes), so every
# output's provenance names the commit the binary was built from.
set(WM_GIT_COMMIT_CC ${CMAKE_BINARY_DIR}/generated/git_commit.cc)
add_custom_target(wm_git_commit
  COMMAND ${CMAKE_COMMAND} -DSOURCE_DIR=${PROJECT_SOURCE_DIR} -DOUTPUT=${WM_GIT_COMMIT_CC}
          -P ${PROJECT_SOURCE_DIR}/cmake/WriteGitCommit.cmake
  BYPRODUCTS ${WM_GIT_COMMIT_CC}
  COMMENT "Recording git commit")

# Writes OUTPUT from TEMPLATE with TRACEMESH_GIT_COMMIT = GIT_COMMIT when given, else `git rev-parse --short HEAD`
# of SOURCE_DIR, or "unknown" when SOURCE_DIR is not a git checkout (a source tarball) or git is missing.
# Run at every build (cmake -P); configure_file rewrites OUTPUT only when the commit changed, so an unchanged
# commit recompiles nothing.
set(TRACEMESH_GIT_COMMIT unknown)
find_program(_git git)
if(GIT_COMMIT)  # -DTRACEMESH_GIT_COMMIT=... at configure time
  set(TRACEMESH_GIT_COMMIT "${GIT_COMMIT}")
elseif(_git AND EXISTS "${SOURCE_DIR}/.git")
  execute_process(COMMAND "${_git}" -C "${SOURCE_DIR}" rev-parse --short HEAD
                  OUTPUT_VARIABLE _commit OUTPUT_STRIP_TRAILING_WHITESPACE ERROR_QUIET RESULT_VARIABLE _status)
  if(_status EQUAL 0 AND _commit MATCHES "^[0-9a-f]+$")
    set(TRACEMESH_GIT_COMMIT "${_commit}")
  endif()
endif()
configure_file("${TEMPLATE}" "${OUTPUT}" @ONLY)

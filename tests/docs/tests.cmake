# The documentation against the code (tests/docs/check_docs.py): options of both programs, routes and parameters
# of the OpenAPI document, the README's size, relative links, no path outside the repository.
if(TARGET tracemesh AND TARGET tracemeshd)
  find_program(TRACEMESH_PYTHON3 python3 REQUIRED)
  add_test(NAME docs.check
           COMMAND ${TRACEMESH_PYTHON3} ${CMAKE_CURRENT_LIST_DIR}/check_docs.py
                   --tracemesh $<TARGET_FILE:tracemesh> --tracemeshd $<TARGET_FILE:tracemeshd>
                   --source ${PROJECT_SOURCE_DIR})
  set_tests_properties(docs.check PROPERTIES TIMEOUT 60 LABELS docs)
endif()

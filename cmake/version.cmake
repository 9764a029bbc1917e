# Writes OUT, a header defining AGVCAL_VERSION: the project version and `git describe` of the
# source tree at build time ("0.1.0 (git c7d975a-dirty)"), or the project version alone outside
# a git checkout. OUT is rewritten only when the text changes, so that an unchanged tree
# recompiles nothing.
execute_process(COMMAND git describe --always --dirty --tags
                WORKING_DIRECTORY ${SOURCE_DIR}
                OUTPUT_VARIABLE describe OUTPUT_STRIP_TRAILING_WHITESPACE
                RESULT_VARIABLE status ERROR_QUIET)
if(status EQUAL 0 AND NOT describe STREQUAL "")
  set(version "${PROJECT_VERSION} (git ${describe})")
else()
  set(version "${PROJECT_VERSION}")
endif()
set(text "#pragma once\n#define AGVCAL_VERSION \"${version}\"\n")
set(old "")
if(EXISTS ${OUT})
  file(READ ${OUT} old)
endif()
if(NOT old STREQUAL text)
  file(WRITE ${OUT} "${text}")
endif()

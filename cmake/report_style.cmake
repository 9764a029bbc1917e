# The reports' one stylesheet, embedded in report_page.cc; the fleet's pages read the same file.
# Included by every build that compiles report_page.cc (the main one and bench/fuzz's): source
# file properties hold only in the directory that sets them.
set(REPORT_STYLE ${CMAKE_SOURCE_DIR}/libcalib/src/io/report_style.css)
set_property(DIRECTORY APPEND PROPERTY CMAKE_CONFIGURE_DEPENDS ${REPORT_STYLE})
file(READ ${REPORT_STYLE} AGVCAL_REPORT_STYLE)
configure_file(${CMAKE_SOURCE_DIR}/cmake/report_style.h.in ${CMAKE_BINARY_DIR}/generated/report_style.h @ONLY)
set_source_files_properties(${CMAKE_SOURCE_DIR}/libcalib/src/io/report_page.cc PROPERTIES
                            INCLUDE_DIRECTORIES ${CMAKE_BINARY_DIR}/generated)

# ips-import (issue 21): the range and position readers, dwell intervals, the site of the rows'
# anchors, fuzzing of the row paths, and the program end to end on small hand-made files and on
# excerpts of two public UWB datasets. Paths relative to tests/.
ips_unit_test(import_test drivers/import/import_rows_test.cpp)
target_link_libraries(import_test PRIVATE ips_import)

ips_fuzz_target(import_rows drivers/import/import_rows_fuzz.cpp ips_import)
ips_fuzz_target(tdoa_rows drivers/import/tdoa_rows_fuzz.cpp ips_import)

# ips-import ranges / poses / site on small files: merged files, tagged lines, --site-out,
# lever arms, dwell, SITE into a log (read back with ips-export), the nothing-silent errors.
add_test(NAME import_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/import_cli.sh ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(import_cli PROPERTIES LABELS integration TIMEOUT 120)

# The real-data path on excerpts of uwb-cucudasluv and uwb-librsf (tests/data/real/uwb-*):
# import counts, then ips-replay and ips-eval with an accuracy bound.
add_test(NAME import_realdata
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/import/import_realdata.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(import_realdata PROPERTIES LABELS integration TIMEOUT 180)

# ips-import tdoa (pairwise TDoA, the UTIL dataset's layout) on small files: counts, skipped
# rows of other sensors, rejected rows with their line, --columns, --channel, nothing silent.
add_test(NAME import_tdoa_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/import/import_tdoa_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(import_tdoa_cli PROPERTIES LABELS integration TIMEOUT 120)

# The raw DW1000 timestamps of uwb-cucudasluv's static rows (committed excerpt) through ips-import
# ranges and ips-export: UWB_TWR_RAW beside UWB_RANGE, the SS-TWR range against the file's Distance,
# --range-from timestamps.
add_test(NAME import_twr_realdata
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/import/import_twr_realdata.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(import_twr_realdata PROPERTIES LABELS integration TIMEOUT 120)

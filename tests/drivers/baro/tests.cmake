# ips-baro (issue 9): the serial line and sysfs value parsers, the sample checks, the IIO reader on
# a fake sysfs tree, the command-line specs, fuzzing, and the program end to end (a fake IIO tree
# and a pseudo-terminal over real LCM multicast) and its start-up errors. Paths relative to tests/.
ips_unit_test(baro_driver_test
  drivers/baro/baro_line_parser_test.cpp
  drivers/baro/sysfs_value_test.cpp
  drivers/baro/baro_reading_test.cpp
  drivers/baro/iio_device_test.cpp
  drivers/baro/sensor_spec_test.cpp
  drivers/baro/baro_file_test.cpp
)
target_link_libraries(baro_driver_test PRIVATE ips_baro)

ips_fuzz_target(baro_lines drivers/baro/baro_lines_fuzz.cpp ips_baro)
ips_fuzz_target(baro_file drivers/baro/baro_file_fuzz.cpp ips_baro)

# Two IIO barometers on a fake sysfs tree (one by name, one by path and a reference station) at
# 10 Hz in a private network namespace: exact BARO values and reference flags; one device removed
# while the other keeps publishing, HEALTH degraded naming it, publishing again once it is back;
# SIGINT status 0; lcm-logger records.
add_test(NAME baro_iio_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/baro/baro_iio_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(baro_iio_netns PROPERTIES LABELS integration TIMEOUT 300
                                               SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# A serial barometer on a pseudo-terminal: exact BARO values of the good lines, the bad lines
# counted in HEALTH with their reasons, an unplug and replug, SIGINT status 0.
add_test(NAME baro_serial_pty_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/baro/baro_serial_pty_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(baro_serial_pty_netns PROPERTIES LABELS integration TIMEOUT 300
                                                      SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# Start-up errors: one line, status 2.
add_test(NAME baro_cli_errors
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/baro/baro_cli_errors.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(baro_cli_errors PROPERTIES LABELS integration TIMEOUT 30)

# --file (issue 21): hand-made recordings (a loruro-like banner, header and rows; P/T lines; two
# files; stdin) to an LCM log, exact counts and values; a wrongly separated file and garbage give
# status 1 with the exact hint.
add_test(NAME baro_file_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/baro_file_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(baro_file_cli PROPERTIES LABELS integration TIMEOUT 60)

# The real baro-loruro recordings (GPL-3.0: read in place from ../shared/realdata or
# $IPS_REALDATA, never copied): oss_0.log's row count; skipped (77) when the folder is absent.
add_test(NAME baro_file_realdata
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/baro_file_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} --realdata)
set_tests_properties(baro_file_realdata PROPERTIES LABELS integration TIMEOUT 60
                                                   SKIP_RETURN_CODE 77)

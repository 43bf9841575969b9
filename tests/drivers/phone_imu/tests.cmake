# ips-phone-imu: the row and JSON parsers, the clock offset, the assembler, fuzzing (with the HTTP
# request parser of core/, tested in tests/core/), and the program end to end (UDP + HTTP in a private network namespace), a file import and its
# start-up errors. Paths relative to tests/.
ips_unit_test(phone_imu_test
  drivers/phone_imu/csv_row_test.cpp
  drivers/phone_imu/sensor_logger_json_test.cpp
  drivers/phone_imu/clock_offset_test.cpp
  drivers/phone_imu/imu_assembler_test.cpp
  drivers/phone_imu/file_import_test.cpp
)
target_link_libraries(phone_imu_test PRIVATE ips_phone_imu)

ips_fuzz_target(phone_imu_rows drivers/phone_imu/phone_imu_rows_fuzz.cpp ips_phone_imu)
ips_fuzz_target(phone_imu_http drivers/phone_imu/phone_imu_http_fuzz.cpp ips_phone_imu)

# The program with a UDP sender and an HTTP client in a private network namespace: exact IMU
# messages, time mapping bounds, parse errors in HEALTH, 404/405/413, a 20000-datagram flood
# without memory growth, SIGINT status 0; lcm-logger records.
add_test(NAME phone_imu_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/phone_imu/phone_imu_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(phone_imu_live_netns PROPERTIES LABELS integration TIMEOUT 300
                                                     SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# --file: a recorded file to an exact LCM log (--out) and onto the bus (--as-fast-as-possible).
add_test(NAME phone_imu_file_import
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/phone_imu/phone_imu_file_import.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(phone_imu_file_import PROPERTIES LABELS integration TIMEOUT 300
                                                      SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# Start-up errors: one line, status 2.
add_test(NAME phone_imu_cli_errors
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/phone_imu/phone_imu_cli_errors.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(phone_imu_cli_errors PROPERTIES LABELS integration TIMEOUT 30)

# --file through core/table_text: the real excerpts (steps-oxford accelerometer-only CSV,
# foot-openshoe at --rate 820), a header by name, --file-start; nothing silent (status 1 with the
# exact hint for a wrong separator, a wrong time unit, garbage).
add_test(NAME phone_imu_file_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/phone_imu_file_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(phone_imu_file_cli PROPERTIES LABELS integration TIMEOUT 60)

# The excerpts of tests/data/real/{steps-oxford,foot-openshoe} through ips-replay (ips-pdr,
# ips-ins): import counts, the PDR's stated drop reason, the INS track's poses and length.
add_test(NAME phone_imu_realdata
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/phone_imu/phone_imu_realdata.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(phone_imu_realdata PROPERTIES LABELS integration TIMEOUT 60)

# The HTTP input cannot be starved (issue 28): 200 idle connections and a slowloris held open
# while 20 uploads each get their 200 within 1 s and reach the bus; HEALTH counts the cuts.
add_test(NAME phone_imu_http_starve_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/phone_imu/phone_imu_http_starve_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(phone_imu_http_starve_netns PROPERTIES LABELS integration TIMEOUT 240
                                                            SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# The HTTP input under abuse (issue 26): a 1000-connection flood, oversized and malformed
# requests, resets, pipelining clients that never read; 20 uploads within 1 s and 28 on the bus,
# peak RSS under 32 MiB, the refusals counted by status (log, HEALTH).
add_test(NAME phone_imu_http_abuse_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/phone_imu/phone_imu_http_abuse_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(phone_imu_http_abuse_netns PROPERTIES LABELS integration TIMEOUT 300
                                                           SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

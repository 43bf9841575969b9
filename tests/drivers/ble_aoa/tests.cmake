# ips-ble-aoa (issue 7): +UUDF and capture-line parsers, the event decoder, the AT conversation,
# fuzzing, and the program end to end on pseudo-terminals over real LCM multicast, replaying a
# capture, and its start-up errors. Paths relative to tests/.
ips_unit_test(ble_aoa_test
  drivers/ble_aoa/uudf_parser_test.cpp
  drivers/ble_aoa/capture_line_test.cpp
  drivers/ble_aoa/event_decoder_test.cpp
  drivers/ble_aoa/at_enabler_test.cpp
  drivers/ble_aoa/uudf_table_test.cpp
)
target_link_libraries(ble_aoa_test PRIVATE ips_ble_aoa)

ips_fuzz_target(ble_aoa_lines drivers/ble_aoa/ble_aoa_lines_fuzz.cpp ips_ble_aoa)
ips_fuzz_target(ble_aoa_uudf_table drivers/ble_aoa/ble_aoa_uudf_table_fuzz.cpp ips_ble_aoa)

# ips-ble-aoa with three fake anchors on pseudo-terminals in a private network namespace: exact
# BLE_AOA messages (ids, angles, legacy range, counters, source, reception time), garbled first
# lines counted, duplicates dropped, one anchor unplugged and replugged while the others keep
# publishing, the AT conversation (incl. ERROR), SIGINT status 0; lcm-logger records.
add_test(NAME ble_aoa_pty_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/ble_aoa/ble_aoa_pty_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(ble_aoa_pty_netns PROPERTIES LABELS integration TIMEOUT 300
                                                  SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# --capture: a CSV capture to an exact LCM log (--out) and onto the bus (--speed, lcm-logger).
add_test(NAME ble_aoa_capture_replay
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/ble_aoa/ble_aoa_capture_replay.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(ble_aoa_capture_replay PROPERTIES LABELS integration TIMEOUT 300
                                                       SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# Start-up errors: one line, status 2.
add_test(NAME ble_aoa_cli_errors
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/ble_aoa/ble_aoa_cli_errors.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(ble_aoa_cli_errors PROPERTIES LABELS integration TIMEOUT 30)

# --capture with files of decoded +UUDF fields (hand-made, in the public datasets' layouts): two
# anchors merged in time order, with and without header, ISO times, numeric ids, --anchor-name and
# --tag-name, a wrongly separated file and garbage (status 1, the exact hint).
add_test(NAME ble_aoa_capture_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/ble_aoa_capture_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(ble_aoa_capture_cli PROPERTIES LABELS integration TIMEOUT 60)

# The real recordings (Byongho96/ble-localization, no licence: read in place from
# $IPS_REALDATA or ../shared/realdata; skipped when absent): one anchor file's import count.
add_test(NAME ble_aoa_realdata_byongho96
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/ble_aoa/ble_aoa_realdata.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(ble_aoa_realdata_byongho96 PROPERTIES LABELS integration TIMEOUT 60
                                                           SKIP_RETURN_CODE 77)

# ips-uwb-serial (issue 5): parsers, decoder, shell driver, the serial transport, fuzzing, and the
# program end to end on pseudo-terminals over real LCM multicast. Paths relative to tests/.
ips_unit_test(uwb_serial_test
  drivers/uwb_serial/pans_parser_test.cpp
  drivers/uwb_serial/range_line_parser_test.cpp
  drivers/uwb_serial/line_decoder_test.cpp
  drivers/uwb_serial/pans_shell_test.cpp
  core/serial_port_test.cpp  # the serial transport (core), tested with its first user
)
target_link_libraries(uwb_serial_test PRIVATE ips_uwb_serial util)

ips_fuzz_target(uwb_serial_lines drivers/uwb_serial/uwb_serial_lines_fuzz.cpp ips_uwb_serial)

# ips-uwb-serial on pseudo-terminals in a private network namespace: PANS and RANGE lines to
# exact messages, garbled lines counted, unplug/replug with HEALTH saying so, missing at start,
# the PANS shell conversation (\r\r, lec, and lec + quit at SIGINT).
add_test(NAME uwb_serial_pty_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/uwb_serial/uwb_serial_pty_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_serial_pty_netns PROPERTIES LABELS integration TIMEOUT 300
                                                     SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# Start-up errors: one line, status 2.
add_test(NAME uwb_serial_cli_errors
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/uwb_serial/uwb_serial_cli_errors.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_serial_cli_errors PROPERTIES LABELS integration TIMEOUT 30)

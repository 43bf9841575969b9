# ips-uwb-tdoa-anchors (issue 5): unit tests, the libFuzzer target, and the program end to end
# over real TCP/UDP on loopback and real LCM multicast in a private network namespace. Included
# from tests/CMakeLists.txt; paths are relative to tests/.
ips_unit_test(uwb_tdoa_anchors_test
  drivers/uwb_tdoa_anchors/anchor_report_parser_test.cpp
  drivers/uwb_tdoa_anchors/record_splitter_test.cpp
  drivers/uwb_tdoa_anchors/wire_ids_test.cpp
)
target_link_libraries(uwb_tdoa_anchors_test PRIVATE ips_uwb_tdoa_anchors)

ips_fuzz_target(anchor_report drivers/uwb_tdoa_anchors/anchor_report_fuzz.cpp ips_uwb_tdoa_anchors)

# Bad command lines, bad files, --help, --to-records and --file on real files: one clear line,
# status 2 or 1 (LCM in memory: no network needed).
add_test(NAME uwb_tdoa_anchors_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/uwb_tdoa_anchors/uwb_tdoa_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_tdoa_anchors_cli PROPERTIES LABELS integration TIMEOUT 60)

# sim -> --to-records -> a Python server over TCP (going away once: reconnect, HEALTH degraded),
# UDP datagrams, a file with garbled records, stdin -> LCM multicast -> lcm-logger, in a private
# network namespace: the simulator's UWB_RX come back exactly, bad records counted.
add_test(NAME uwb_tdoa_anchors_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/uwb_tdoa_anchors/uwb_tdoa_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_tdoa_anchors_netns PROPERTIES LABELS integration TIMEOUT 300
                                                       SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

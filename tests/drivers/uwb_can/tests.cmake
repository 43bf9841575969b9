# ips-uwb-can (issue 5): unit tests, libFuzzer targets, integration tests. Included from
# tests/CMakeLists.txt; paths are relative to tests/.
ips_unit_test(uwb_can_test
  drivers/uwb_can/can_range_frame_test.cpp
  drivers/uwb_can/candump_parser_test.cpp
  drivers/uwb_can/can_range_receiver_test.cpp
)
target_link_libraries(uwb_can_test PRIVATE ips_uwb_can)

ips_fuzz_target(candump_line drivers/uwb_can/candump_line_fuzz.cpp ips_uwb_can)
ips_fuzz_target(can_range_frame drivers/uwb_can/can_range_frame_fuzz.cpp ips_uwb_can)

# Bad command lines and no SocketCAN here: one clear line, status 2 or 1; --to-candump on files.
add_test(NAME uwb_can_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/uwb_can/uwb_can_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_can_cli PROPERTIES LABELS integration TIMEOUT 60)

# sim -> --to-candump -> --candump-file / --candump-stdin -> LCM multicast -> lcm-logger, in a
# private network namespace: the simulator's ranges come back.
add_test(NAME uwb_can_candump_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/uwb_can/candump_replay_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_can_candump_netns PROPERTIES LABELS integration TIMEOUT 300
                                                      SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# cansend -> vcan0 -> ips-uwb-can -> LCM; skipped (77, with the reason) without vcan or cansend.
add_test(NAME uwb_can_vcan_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/drivers/uwb_can/vcan_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_can_vcan_netns PROPERTIES LABELS integration TIMEOUT 300
                                                   SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# ips-pdr (issue 8). Paths relative to tests/.
ips_unit_test(pdr_test
  estimators/pdr/pdr_units_test.cpp
  estimators/pdr/pdr_accuracy_test.cpp
)
target_link_libraries(pdr_test PRIVATE ips_pdr)

# ips-pdr calibrate on a simulated 200 m walk (step_k found from a wrong start), ips-replay
# --only pdr, and bad command lines (one line, status 2). No network needed.
add_test(NAME pdr_calibrate_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/pdr/pdr_calibrate_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(pdr_calibrate_cli PROPERTIES LABELS integration TIMEOUT 120)

# sim (walk-square at 20x) -> ips-pdr -> lcm-logger over LCM multicast in a private network
# namespace: the steps and the loop closure of the in-process run.
add_test(NAME pdr_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/pdr/pdr_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(pdr_live_netns PROPERTIES LABELS integration TIMEOUT 120
                                               SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

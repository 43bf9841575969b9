# ips-aoa (issue 7): model, solvers, estimator, accuracy on the simulated hall (with and without
# calibration), live over LCM. Paths relative to tests/.
ips_unit_test(aoa_test
  estimators/aoa/aoa_solvers_test.cpp
  estimators/aoa/aoa_estimator_test.cpp
  estimators/aoa/aoa_accuracy_test.cpp
  estimators/aoa/epoch_grouper_test.cpp
)
target_link_libraries(aoa_test PRIVATE ips_aoa)

# sim (aoa-hall at 10x) -> ips-aoa -> lcm-logger over LCM multicast in a private network
# namespace; ips-eval scores POSE_AOA (EKF and --method lm), ips-replay regenerates it exactly.
add_test(NAME aoa_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/aoa_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(aoa_live_netns PROPERTIES LABELS integration TIMEOUT 120
                                               SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# ips-aoa-calibrate: its fit, the simulated calibration capture, its command line.
include(estimators/aoa/calibrate_tests.cmake)

# ips-altitude (issue 9): the barometric formulas, the measurement model, the estimator and the
# offset calibration on synthetic readings, accuracy on the simulated height steps of 003, live
# over LCM. Paths relative to tests/.
ips_unit_test(altitude_test
  estimators/altitude/barometric_test.cpp
  estimators/altitude/altitude_estimator_test.cpp
  estimators/altitude/offset_calibration_test.cpp
  estimators/altitude/altitude_accuracy_test.cpp
  estimators/altitude/altitude_noise_test.cpp
)
target_link_libraries(altitude_test PRIVATE ips_altitude)

# Calibration from a simulated capture, then sim (baro-steps at 20x) -> ips-altitude ->
# lcm-logger over LCM multicast in a private network namespace; replay identical to live; a
# missing reference in HEALTH; --help and start-up errors.
add_test(NAME altitude_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/altitude/altitude_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(altitude_live_netns PROPERTIES LABELS integration TIMEOUT 120
                                                    SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

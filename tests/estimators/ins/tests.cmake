# ips-ins (issue 8): stance detector, strapdown filter, ZUPT, estimator on synthetic and
# noise-free simulated data, accuracy on the foot scenarios, live over LCM. Paths relative to
# tests/.
ips_unit_test(ins_test
  estimators/ins/ins_estimator_test.cpp
  estimators/ins/ins_accuracy_test.cpp
)
target_link_libraries(ins_test PRIVATE ips_ins)

# sim (walk-square-foot at 10x) -> ips-ins -> lcm-logger over LCM multicast in a private network
# namespace; ips-eval scores POSE_INS; --help and start-up errors.
add_test(NAME ins_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/ins/ins_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(ins_live_netns PROPERTIES LABELS integration TIMEOUT 120
                                               SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

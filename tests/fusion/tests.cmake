# ips-fuse (issue 10): the estimator on synthetic inputs, accuracy on the corridor scenarios and
# on baro-steps (with ips-uwb-tdoa and ips-altitude). Paths relative to tests/.
ips_unit_test(fuse_test
  fusion/fuse_estimator_test.cpp
  fusion/fuse_corridor_test.cpp
  fusion/fuse_baro_steps_test.cpp
)
target_link_libraries(fuse_test PRIVATE ips_fuse ips_altitude ips_uwb_tdoa)

# sim (corridor-L-2 at 10x) -> ips-fuse -> lcm-logger over LCM multicast in a private network
# namespace; ips-eval scores POSE_FUSED; --help and start-up errors.
add_test(NAME fuse_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/fusion/fuse_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(fuse_live_netns PROPERTIES LABELS integration TIMEOUT 60
                                                SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

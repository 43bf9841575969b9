# ips-fuse (issue 10): the estimator on synthetic inputs, accuracy on the corridor scenarios and
# on baro-steps (with ips-uwb-tdoa and ips-altitude). Paths relative to tests/.
ips_unit_test(fuse_test
  fusion/fuse_estimator_test.cpp
  fusion/fuse_corridor_test.cpp
  fusion/fuse_baro_steps_test.cpp
)
target_link_libraries(fuse_test PRIVATE ips_fuse ips_altitude ips_uwb_tdoa)

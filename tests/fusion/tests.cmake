# ips-fuse (issue 10): accuracy on the corridor scenarios. Paths relative to tests/.
ips_unit_test(fuse_test
  fusion/fuse_estimator_test.cpp
  fusion/fuse_corridor_test.cpp
)
target_link_libraries(fuse_test PRIVATE ips_fuse)

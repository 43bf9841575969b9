# ips-aoa (issue 7): model, solvers, estimator, accuracy on the simulated hall. Paths relative to tests/.
ips_unit_test(aoa_test
  estimators/aoa/aoa_solvers_test.cpp
  estimators/aoa/aoa_estimator_test.cpp
  estimators/aoa/aoa_accuracy_test.cpp
)
target_link_libraries(aoa_test PRIVATE ips_aoa)

# ips-aoa-calibrate (issue 7): the fit on exact synthetic pairs, the collector and the site file
# it writes; on the simulator (aoa-hall-calibration) the recovered anchor biases and the
# calibration used on the aoa-hall walk. Included from tests.cmake; paths relative to tests/.
ips_unit_test(aoa_calibrate_test
  estimators/aoa/calibration_fit_test.cpp
  estimators/aoa/calibration_sim_test.cpp)
target_link_libraries(aoa_calibrate_test PRIVATE ips_aoa)

# ips-sim --scenario aoa-hall-calibration, then ips-aoa-calibrate on the log: the table, the
# written site's calibration block, and the error paths (one line, status 2).
add_test(NAME aoa_calibrate_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/aoa/aoa_calibrate_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(aoa_calibrate_cli PROPERTIES LABELS integration TIMEOUT 120)

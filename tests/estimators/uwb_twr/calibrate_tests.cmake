# ips-uwb-calibrate (issue 27): the per-pair offset fit on exact synthetic ranges and on the
# simulated lab with biased radios; its command line on a simulated capture. Paths relative to
# tests/.
ips_unit_test(uwb_calibrate_test estimators/uwb_twr/range_calibration_test.cpp)

# ips-sim (lab with pair offsets 0.1 to 0.3 m) -> ips-uwb-calibrate: the table, the written site
# read back (its offsets bring the capture's residual medians to zero), the error paths.
add_test(NAME uwb_calibrate_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/uwb_twr/uwb_calibrate_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(uwb_calibrate_cli PROPERTIES LABELS integration TIMEOUT 120)

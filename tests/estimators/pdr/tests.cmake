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

# ips-uwb-survey: the survey on exact and noisy geometry, the lab accuracy, the site it writes.
ips_unit_test(uwb_survey_test
  estimators/uwb_survey/anchor_survey_test.cpp
  estimators/uwb_survey/anchor_delays_test.cpp
  estimators/uwb_survey/anchor_delays_sim_test.cpp
  estimators/uwb_survey/range_collector_test.cpp
  estimators/uwb_survey/lab_survey_test.cpp)
target_link_libraries(uwb_survey_test PRIVATE ips_uwb_survey)

# ips-uwb-survey on a simulated lab log: the written site, the mirror, and the error paths.
add_test(NAME uwb_survey_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/uwb_survey_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(uwb_survey_cli PROPERTIES LABELS integration TIMEOUT 120)

# ips-uwb-survey --offsets on a simulated lab log with device delays: the table, the site written
# with range_offsets_m, the keys kept, and the error paths.
add_test(NAME uwb_survey_offsets_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/uwb_survey_offsets_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(uwb_survey_offsets_cli PROPERTIES LABELS integration TIMEOUT 120)

# ips-site (tools/site/, issue 23): its reload logic, its command line, and live over LCM multicast.
# Paths relative to tests/. fuzz_site_keeper (clang sanitizer build) feeds the keeper any text: the
# site loader (fuzz_site_file fuzzes it alone) and then every estimator's own section checks.
ips_unit_test(site_keeper_test tools/site/site_keeper_test.cpp)
target_link_libraries(site_keeper_test PRIVATE ips_site_keeper)

add_test(NAME site_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/tools/site/site_cli.sh ${CMAKE_RUNTIME_OUTPUT_DIRECTORY}
                 ${PROJECT_SOURCE_DIR})
set_tests_properties(site_cli PROPERTIES LABELS integration TIMEOUT 60)

# ips-site, ips-uwb-twr without --site, ips-sim without its SITE, the real lcm-logger: the site
# taken, an anchor moved, a broken edit refused (HEALTH), SIGHUP.
add_test(NAME site_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/tools/site/site_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(site_live_netns PROPERTIES LABELS integration TIMEOUT 300 SKIP_RETURN_CODE 77
                                                RESOURCE_LOCK cpu_heavy)
ips_fuzz_target(site_keeper tools/site/site_keeper_fuzz.cpp ips_site_keeper)

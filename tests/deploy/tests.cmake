# ips-deploy (tools/deploy/): the deployment file and its errors, commands and environment,
# the systemd units (systemd >= 254 and 252), the restart back-off and policy, the run file, and
# the status table from HEALTH. Paths relative to tests/.
ips_unit_test(deploy_test deploy/deploy_test.cpp)
target_link_libraries(deploy_test PRIVATE ips_deploy)

# ips-deploy on one machine: check, systemd units (for 254 and 252; systemd-analyze verify of
# those for this machine's systemd), programs not found, run with restarts, back-off and stop
# timeouts, each exit printed once, the hostname warning, working_dir and --working-dir.
add_test(NAME deploy_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/deploy/deploy_cli.sh ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(deploy_cli PROPERTIES LABELS integration TIMEOUT 120)
# Three machines (network namespaces on a bridge, ttl=1 multicast) under ips-deploy run: status,
# the recording, the lab bound, a killed tracker restarted.
add_test(NAME deploy_multihost_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/deploy/deploy_multihost_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(deploy_multihost_netns PROPERTIES LABELS integration TIMEOUT 180
                                                       SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)
# status of a run on this machine whose file names another hostname: matched by the run file's
# pids (real multicast in a private network namespace); a process started by hand kept apart.
add_test(NAME deploy_status_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/deploy/deploy_status_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(deploy_status_netns PROPERTIES LABELS integration TIMEOUT 180
                                                    SKIP_RETURN_CODE 77)
ips_fuzz_target(deploy_file deploy/deploy_file_fuzz.cpp ips_deploy)

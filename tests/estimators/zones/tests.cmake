# ips-zones (issue 24 items 3, 4): the core's zones and alerts on made-up tracks, and the lab
# scenario's zones through ips-sim, ips-replay and the live ips-zones. Paths relative to tests/.
ips_unit_test(zones_test estimators/zones/zone_monitor_test.cpp)
target_link_libraries(zones_test PRIVATE ips_zones)

# The lab's zones: on TRUTH exactly the truth crossings, on POSE_FUSED within 0.5 s, replay
# byte-identical (ips-sim --out, ips-replay); live over LCM multicast in a private network
# namespace with the alerts (silent tag, degraded and gone processes); the command line.
add_test(NAME zones_lab_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/zones/zones_lab_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(zones_lab_netns PROPERTIES LABELS integration TIMEOUT 180
                                                SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

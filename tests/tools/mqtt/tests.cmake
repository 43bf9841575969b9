# ips-mqtt (tools/mqtt/, issue 24 item 5): the mapping of messages to topics and JSON, and live
# against a real mosquitto broker in a private network namespace. Paths relative to tests/.
find_package(nlohmann_json 3.10 REQUIRED)
ips_unit_test(mqtt_mapping_test tools/mqtt/mqtt_mapping_test.cpp)
target_link_libraries(mqtt_mapping_test PRIVATE ips_mqtt_mapping nlohmann_json::nlohmann_json)

# Publishes the poses, zone events, alerts and HEALTH the live test checks (nobody else publishes
# zone_event_t and alert_t yet). Not an ips-* program: no page of its own.
add_executable(mqtt_bus_publish tools/mqtt/mqtt_bus_publish.cpp)
target_link_libraries(mqtt_bus_publish PRIVATE ips_lcmtypes lcm::lcm)
ips_target_defaults(mqtt_bus_publish)

# mosquitto on loopback, ips-mqtt, ips-site and mosquitto_sub: every message's topic and JSON, the
# rate limit, a password, and a broker killed and restarted mid-run (degraded, then OK; what was
# lost counted). Skipped (77) without mosquitto.
add_test(NAME mqtt_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/tools/mqtt/mqtt_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(mqtt_live_netns PROPERTIES LABELS integration TIMEOUT 240 SKIP_RETURN_CODE 77
                                                RESOURCE_LOCK cpu_heavy)
ips_fuzz_target(mqtt_mapping tools/mqtt/mqtt_mapping_fuzz.cpp ips_mqtt_mapping
                nlohmann_json::nlohmann_json)

add_test(NAME mqtt_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/tools/mqtt/mqtt_cli.sh ${CMAKE_RUNTIME_OUTPUT_DIRECTORY}
                 ${PROJECT_SOURCE_DIR})
set_tests_properties(mqtt_cli PROPERTIES LABELS integration TIMEOUT 60)

# ips-view (issue 11): the view model (tracks, trails, channel table, health, JSON) and the SVG
# floor map. Paths relative to tests/.
ips_unit_test(view_test viewer/view_model_test.cpp viewer/svg_render_test.cpp)
target_link_libraries(view_test PRIVATE ips_view)
ips_fuzz_target(view_log viewer/view_log_fuzz.cpp ips_view)

# ips-view on a log: every HTTP route, paced playback, SVG/PNG rendering, start-up errors.
add_test(NAME view_log_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/viewer/view_log_cli.sh ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(view_log_cli PROPERTIES LABELS integration TIMEOUT 120)
# ips-view live over LCM multicast in a private network namespace, with Debian's headless
# Chromium loading the page (screenshot: BUILD/test-output/viewer-live.png).
add_test(NAME view_browser_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/viewer/view_browser_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(view_browser_netns PROPERTIES LABELS integration TIMEOUT 180
                                                   SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)
# ips-view cannot be starved (issue 28): 200 idle connections and a slowloris held open while
# 20 page loads each get the page within 1 s; HEALTH counts the cuts.
add_test(NAME view_http_starve_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/viewer/view_http_starve_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(view_http_starve_netns PROPERTIES LABELS integration TIMEOUT 240
                                                       SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)
# ips-view under abuse (issue 26): a 1000-connection flood, oversized and malformed requests,
# resets, 48 clients that never read (pipelined pages, event streams); 20 page loads within 1 s,
# peak RSS under 64 MiB, the refusals counted by status (log, /api/info, HEALTH).
add_test(NAME view_http_abuse_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/viewer/view_http_abuse_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(view_http_abuse_netns PROPERTIES LABELS integration TIMEOUT 300
                                                      SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# ips-view as the lab's console (issue 24): a log written by view_console_log (two floors with
# plans, zones, zone events, alerts) played to Debian's headless Chromium through chromedriver:
# channel and tag toggles, zoom, follow, seek, floor change, zone event, alert and its
# acknowledgement; screenshots in BUILD/test-output/viewer-console-*.png.
add_executable(view_console_log viewer/view_console_log.cpp)
target_link_libraries(view_console_log PRIVATE ips_core)
ips_target_defaults(view_console_log)
add_test(NAME view_console
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/viewer/view_console.sh ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(view_console PROPERTIES LABELS integration TIMEOUT 180 SKIP_RETURN_CODE 77
                                             RESOURCE_LOCK cpu_heavy)

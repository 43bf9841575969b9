# ips-uwb-tdoa: unit and accuracy tests (in-process simulator), the rank-masters command line on
# simulated logs, and the program live over real LCM multicast in a private network namespace.
# Included from tests/CMakeLists.txt; paths are relative to tests/.
ips_unit_test(uwb_tdoa_test
  estimators/uwb_tdoa/clock_sync_test.cpp
  estimators/uwb_tdoa/tdoa_estimator_test.cpp
  estimators/uwb_tdoa/tdoa_accuracy_test.cpp
  estimators/uwb_tdoa/master_ranking_test.cpp
  estimators/uwb_tdoa/tdoa_pair_test.cpp
)
target_link_libraries(uwb_tdoa_test PRIVATE ips_uwb_tdoa)

# rank-masters on six simulated static-tag logs (one per sync master), and bad command lines and
# files: one clear line, status 2 (1 when no log holds an estimate). No network needed.
add_test(NAME uwb_tdoa_rank_masters_cli
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/uwb_tdoa_rank_masters_cli.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY} ${PROJECT_SOURCE_DIR})
set_tests_properties(uwb_tdoa_rank_masters_cli PROPERTIES LABELS integration TIMEOUT 120)

# sim (tdoa-hall at 10x) -> ips-uwb-tdoa -> lcm-logger over LCM multicast in a private network
# namespace; ips-eval scores POSE_TDOA, ips-export checks CLOCK.
add_test(NAME uwb_tdoa_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/uwb_tdoa_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_tdoa_live_netns PROPERTIES LABELS integration TIMEOUT 180
                                                    SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

# Pairwise TDoA through the programs: ips-sim --scenario loco-tdoa -> ips-replay -> ips-eval (no
# network): RMSE bound, the gated pairs of the NLOS anchor in the account.
add_test(NAME uwb_tdoa_pairs_replay
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/estimators/uwb_tdoa/uwb_tdoa_pairs_replay.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_tdoa_pairs_replay PROPERTIES LABELS integration TIMEOUT 120)

# sim (loco-tdoa: UWB_TDOA pairs only, at 10x) -> ips-uwb-tdoa -> lcm-logger over LCM multicast in
# a private network namespace; ips-eval scores POSE_TDOA.
add_test(NAME uwb_tdoa_pairs_live_netns
         COMMAND ${CMAKE_CURRENT_SOURCE_DIR}/integration/uwb_tdoa_pairs_live_netns.sh
                 ${CMAKE_RUNTIME_OUTPUT_DIRECTORY})
set_tests_properties(uwb_tdoa_pairs_live_netns PROPERTIES LABELS integration TIMEOUT 120
                                                          SKIP_RETURN_CODE 77 RESOURCE_LOCK cpu_heavy)

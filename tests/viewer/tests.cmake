# ips-view (issue 11): the view model (tracks, trails, channel table, health, JSON) and the SVG
# floor map. Paths relative to tests/.
ips_unit_test(view_test viewer/view_model_test.cpp viewer/svg_render_test.cpp)
target_link_libraries(view_test PRIVATE ips_view)

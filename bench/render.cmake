# Render benchmarks (not part of `make test`): include() this after demnerf_render exists.
#   render_synth_bench : seconds per synthetic scene (tbar, cuboid, cook; 48 + 8 views, 200 px;
#                        median of 3), optionally docs/tbar_contact_sheet.png (--contact-sheet)
#                        and the T-bar moved by a twist field (--twist-degrees 20)
if(NOT TARGET render_synth_bench)
  add_executable(render_synth_bench ${CMAKE_CURRENT_LIST_DIR}/render_synth_bench.cpp)
  target_link_libraries(render_synth_bench PRIVATE demnerf_render)
  set_target_properties(render_synth_bench PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
endif()

# render_deformed_bench : the NeRF rendered deformed by a result vs `demnerf synth --result`
#                         ground truth (PSNR, seconds per view), docs/deformed_render.png
if(NOT TARGET render_deformed_bench)
  add_executable(render_deformed_bench ${CMAKE_CURRENT_LIST_DIR}/render_deformed_bench.cpp)
  target_link_libraries(render_deformed_bench PRIVATE demnerf_render)
  set_target_properties(render_deformed_bench PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
endif()

# NeRF benchmarks (packages/nerf): included by packages/nerf/CMakeLists.txt when
# DEMNERF_NERF_BENCH is ON. Executables land in <build>/bin/bench.
foreach(name nerf_train nerf_kernels nerf_render_sweep nerf_density_probe)
  add_executable(${name} ${DEMNERF_ROOT_DIR}/bench/${name}.cpp)
  target_link_libraries(${name} PRIVATE demnerf_nerf)
  set_target_properties(${name} PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
endforeach()

# Mechanics benchmarks (not part of `make test`): include() this after demnerf_mechanics exists.
add_executable(mechanics_cook ${CMAKE_CURRENT_LIST_DIR}/mechanics_cook.cpp)
target_link_libraries(mechanics_cook PRIVATE demnerf_mechanics)
set_target_properties(mechanics_cook PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_tbar ${CMAKE_CURRENT_LIST_DIR}/mechanics_tbar.cpp)
target_link_libraries(mechanics_tbar PRIVATE demnerf_mechanics)
target_compile_definitions(mechanics_tbar PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
set_target_properties(mechanics_tbar PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_dem ${CMAKE_CURRENT_LIST_DIR}/mechanics_dem.cpp)
target_link_libraries(mechanics_dem PRIVATE demnerf_mechanics)
target_compile_definitions(mechanics_dem PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
set_target_properties(mechanics_dem PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_pinn ${CMAKE_CURRENT_LIST_DIR}/mechanics_pinn.cpp)
target_link_libraries(mechanics_pinn PRIVATE demnerf_mechanics)
target_compile_definitions(mechanics_pinn PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
set_target_properties(mechanics_pinn PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_tbar_fem ${CMAKE_CURRENT_LIST_DIR}/mechanics_tbar_fem.cpp)
target_link_libraries(mechanics_tbar_fem PRIVATE demnerf_mechanics)
target_compile_definitions(mechanics_tbar_fem PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
set_target_properties(mechanics_tbar_fem PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_convergence ${CMAKE_CURRENT_LIST_DIR}/mechanics_convergence.cpp)
target_link_libraries(mechanics_convergence PRIVATE demnerf_mechanics)  # OpenCV comes with demnerf_core
target_compile_definitions(mechanics_convergence PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
set_target_properties(mechanics_convergence PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_cgal_probe ${CMAKE_CURRENT_LIST_DIR}/mechanics_cgal_probe.cpp)
target_link_libraries(mechanics_cgal_probe PRIVATE demnerf_mechanics)
set_target_properties(mechanics_cgal_probe PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_inside_probe ${CMAKE_CURRENT_LIST_DIR}/mechanics_inside_probe.cpp)
target_link_libraries(mechanics_inside_probe PRIVATE demnerf_mechanics)
set_target_properties(mechanics_inside_probe PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
add_executable(mechanics_fem_convergence ${CMAKE_CURRENT_LIST_DIR}/mechanics_fem_convergence.cpp)
target_link_libraries(mechanics_fem_convergence PRIVATE demnerf_mechanics)
set_target_properties(mechanics_fem_convergence PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")

# mechanics_matrix: the solver matrix of issue 13 (docs/mechanics_matrix.{csv,md,png}). Its NeRF
# rows train and extract a NeRF (demnerf_nerf, demnerf_render) and its clouds come from the
# product's samplers (demnerf_geometry); in the root build bench/CMakeLists.txt includes this after
# every library, so they exist.
if(NOT COMMAND demnerf_mechanics_matrix_bench)
  function(demnerf_mechanics_matrix_bench)
    if(TARGET mechanics_matrix OR NOT TARGET demnerf_render OR NOT TARGET demnerf_geometry)
      return()
    endif()
    # Torch's and OpenMP's imported targets are directory-scoped: find them where the bench is.
    find_package(Torch REQUIRED)
    find_package(OpenMP REQUIRED)
    add_executable(mechanics_matrix ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix.cpp
                                    ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_cases.cpp
                                    ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_nerf.cpp
                                    ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_report.cpp
                                    ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_settings.cpp)
    target_link_libraries(mechanics_matrix PRIVATE demnerf_mechanics demnerf_geometry demnerf_render demnerf_nerf)
    # mechanics_matrix_merge: one report from the CSVs of several runs (columns run separately).
    add_executable(mechanics_matrix_merge ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_merge.cpp
                                          ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_csv.cpp
                                          ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_report.cpp)
    target_link_libraries(mechanics_matrix_merge PRIVATE demnerf_core)  # OpenCV comes with core
    set_target_properties(mechanics_matrix_merge PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
    target_compile_definitions(mechanics_matrix PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
    set_target_properties(mechanics_matrix PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
    # mechanics_mlp: the paper's DEM (MLP alone) on one matrix cloud, with its error-vs-time curve.
    add_executable(mechanics_mlp ${DEMNERF_ROOT_DIR}/bench/mechanics_mlp.cpp ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_cases.cpp)
    target_link_libraries(mechanics_mlp PRIVATE demnerf_mechanics demnerf_geometry demnerf_render)
    target_compile_definitions(mechanics_mlp PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
    set_target_properties(mechanics_mlp PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
    # mechanics_mlp_fit: what the MLP of `--method mlp` can represent (a least-squares fit to the
    # reference FEM), and the DEM's check and training started from that fit.
    add_executable(mechanics_mlp_fit ${DEMNERF_ROOT_DIR}/bench/mechanics_mlp_fit.cpp ${DEMNERF_ROOT_DIR}/bench/mechanics_mlp_torch.cpp
                   ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_cases.cpp)
    target_link_libraries(mechanics_mlp_fit PRIVATE demnerf_mechanics demnerf_geometry demnerf_render)
    target_compile_definitions(mechanics_mlp_fit PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
    set_target_properties(mechanics_mlp_fit PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
    # mechanics_mlp_gn: a Gauss-Newton (energy natural gradient) optimiser of the same network and
    # energy, against the product's L-BFGS (issue 13, the T-bar twist).
    add_executable(mechanics_mlp_gn ${DEMNERF_ROOT_DIR}/bench/mechanics_mlp_gn.cpp ${DEMNERF_ROOT_DIR}/bench/mechanics_mlp_torch.cpp
                   ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_cases.cpp)
    target_link_libraries(mechanics_mlp_gn PRIVATE demnerf_mechanics demnerf_geometry demnerf_render)
    target_compile_definitions(mechanics_mlp_gn PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
    set_target_properties(mechanics_mlp_gn PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
    # mechanics_quadrature_probe: the default DEM's quadrature, load, held faces and inside test on
    # one scenario's matrix clouds, against the exact surface (no solve).
    add_executable(mechanics_quadrature_probe ${DEMNERF_ROOT_DIR}/bench/mechanics_quadrature_probe.cpp
                                              ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_cases.cpp)
    target_link_libraries(mechanics_quadrature_probe PRIVATE demnerf_mechanics demnerf_geometry demnerf_render)
    target_compile_definitions(mechanics_quadrature_probe PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
    set_target_properties(mechanics_quadrature_probe PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
    # mechanics_body_probe: the body, grid and loads the default DEM gets from clouds of a given
    # surface (a NeRF extraction), against the surface and the reference FEM's CGAL mesh (no solve).
    add_executable(mechanics_body_probe ${DEMNERF_ROOT_DIR}/bench/mechanics_body_probe.cpp
                                        ${DEMNERF_ROOT_DIR}/bench/mechanics_matrix_cases.cpp)
    target_link_libraries(mechanics_body_probe PRIVATE demnerf_mechanics demnerf_geometry demnerf_render)
    target_include_directories(mechanics_body_probe PRIVATE ${DEMNERF_ROOT_DIR}/packages/mechanics/src)
    target_compile_definitions(mechanics_body_probe PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
    set_target_properties(mechanics_body_probe PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
  endfunction()
endif()
demnerf_mechanics_matrix_bench()  # standalone mechanics build: only when render was added too
add_executable(mechanics_patch_response ${CMAKE_CURRENT_LIST_DIR}/mechanics_patch_response.cpp)
target_link_libraries(mechanics_patch_response PRIVATE demnerf_mechanics)
target_compile_definitions(mechanics_patch_response PRIVATE DEMNERF_ROOT="${DEMNERF_ROOT_DIR}")
set_target_properties(mechanics_patch_response PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")

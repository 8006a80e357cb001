# Geometry benchmarks (not part of `make test`): include() this after demnerf_geometry exists.
#   geometry_sampling_bench  : seconds per sampler on spot.obj at 2 % of its diagonal (median of 3)
#   geometry_samplers_figure : docs/samplers.png, the three samplers on the same mesh
find_package(nlohmann_json REQUIRED)
foreach(tool geometry_sampling_bench geometry_samplers_figure)
  if(TARGET ${tool})  # included twice (package option and bench/CMakeLists.txt)
    continue()
  endif()
  add_executable(${tool} ${CMAKE_CURRENT_LIST_DIR}/${tool}.cpp)
  target_link_libraries(${tool} PRIVATE demnerf_geometry nlohmann_json::nlohmann_json)
  target_compile_definitions(${tool} PRIVATE DEMNERF_SHARED_DIR="${DEMNERF_ROOT_DIR}/../shared"
                                             DEMNERF_SOURCE_DIR="${DEMNERF_ROOT_DIR}")
  set_target_properties(${tool} PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
endforeach()

# geometry_tbar_extraction: trains (or loads) a NeRF of the synthetic T-bar and measures the
# extracted mesh against the exact one. It needs demnerf_nerf and demnerf_render, which
# demnerf_geometry does not depend on (render already depends on nerf; geometry stays torch-free).
# In the root build bench/CMakeLists.txt includes this after every library; standalone, the two
# packages are pulled in here.
if(NOT COMMAND demnerf_geometry_tbar_bench)
  function(demnerf_geometry_tbar_bench)
    if(TARGET geometry_tbar_extraction OR NOT TARGET demnerf_render)
      return()
    endif()
    # Torch's and OpenMP's imported targets are directory-scoped: find them where the bench is.
    find_package(Torch REQUIRED)
    find_package(OpenMP REQUIRED)
    add_executable(geometry_tbar_extraction ${DEMNERF_ROOT_DIR}/bench/geometry_tbar_extraction.cpp)
    target_link_libraries(geometry_tbar_extraction PRIVATE demnerf_geometry demnerf_render demnerf_nerf
                                                           nlohmann_json::nlohmann_json)
    set_target_properties(geometry_tbar_extraction PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")
  endfunction()
endif()
# Standalone geometry build: pull in render (and nerf) for it; in the root build they exist already.
if(NOT TARGET demnerf_render AND EXISTS ${DEMNERF_ROOT_DIR}/packages/render/CMakeLists.txt)
  add_subdirectory(${DEMNERF_ROOT_DIR}/packages/render ${CMAKE_BINARY_DIR}/render)
endif()
demnerf_geometry_tbar_bench()

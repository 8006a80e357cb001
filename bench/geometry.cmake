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
  set_target_properties(${tool} PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin")
endforeach()

# Mechanics benchmarks (not part of `make test`): include() this after demnerf_mechanics exists.
add_executable(mechanics_cook ${CMAKE_CURRENT_LIST_DIR}/mechanics_cook.cpp)
target_link_libraries(mechanics_cook PRIVATE demnerf_mechanics)
set_target_properties(mechanics_cook PROPERTIES RUNTIME_OUTPUT_DIRECTORY "${CMAKE_BINARY_DIR}/bin/bench")

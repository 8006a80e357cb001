# Included by find_package(dem_nerf) / find_package(catkin COMPONENTS dem_nerf) in a package that
# depends on dem_nerf. Its libraries are static archives, so whoever links them needs the system
# libraries they were built against, after them on the link line: found here, as the libraries'
# own CMakeLists find them.
find_package(Eigen3 REQUIRED NO_MODULE)
find_package(OpenCV REQUIRED COMPONENTS core imgproc imgcodecs)
find_package(Torch REQUIRED)
find_package(OpenMP REQUIRED)
find_package(Threads REQUIRED)
find_package(yaml-cpp REQUIRED)
set(CGAL_DO_NOT_WARN_ABOUT_CMAKE_BUILD_TYPE TRUE)
find_package(CGAL 5.4 REQUIRED)
find_package(VTK 9 REQUIRED COMPONENTS CommonCore CommonDataModel CommonMisc IOXML)
list(APPEND dem_nerf_LIBRARIES Eigen3::Eigen ${OpenCV_LIBS} ${TORCH_LIBRARIES} OpenMP::OpenMP_CXX Threads::Threads
     yaml-cpp CGAL::CGAL VTK::CommonCore VTK::CommonDataModel VTK::CommonMisc VTK::IOXML ${CMAKE_DL_LIBS})
list(APPEND dem_nerf_INCLUDE_DIRS ${OpenCV_INCLUDE_DIRS})

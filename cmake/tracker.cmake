# C++ part of hri_sync: the skeleton tracker (roscpp node), the virtual Kinect
# OpenNI2 driver, tools and tests. Included from CMakeLists.txt.

set(CMAKE_CXX_STANDARD 17)
set(CMAKE_CXX_STANDARD_REQUIRED ON)
# Every C++ target below builds warning-free with these (issue 13).
add_compile_options(-Wall -Wextra)

find_path(OPENNI2_INCLUDE_DIR OpenNI.h PATH_SUFFIXES openni2)
find_library(OPENNI2_LIBRARY NAMES OpenNI2)
if(NOT OPENNI2_INCLUDE_DIR OR NOT OPENNI2_LIBRARY)
  message(FATAL_ERROR "OpenNI2 not found: apt-get install libopenni2-dev")
endif()
get_filename_component(OPENNI2_LIB_DIR ${OPENNI2_LIBRARY} REALPATH)
get_filename_component(OPENNI2_LIB_DIR ${OPENNI2_LIB_DIR} DIRECTORY)
find_package(Threads REQUIRED)

# A private OpenNI2 folder: libOpenNI2.so.0 (symlink to the system one) with an
# OpenNI2/Drivers folder holding the stock drivers and the virtual Kinect.
# OpenNI2 loads drivers from beside the libOpenNI2.so.0 it was loaded from; our
# executables find it through their RUNPATH, other programs through
# LD_LIBRARY_PATH (scripts/openni2_env.sh).
set(HRI_SYNC_OPENNI2_DEVEL ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION}/openni2)
set(HRI_SYNC_OPENNI2_INSTALL ${CMAKE_INSTALL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION}/openni2)
set(HRI_SYNC_STOCK_DRIVERS OniFile PS1080 PSLink)

function(hri_sync_openni2_links dir)
  file(MAKE_DIRECTORY ${dir}/OpenNI2/Drivers)
  execute_process(COMMAND ${CMAKE_COMMAND} -E create_symlink
    ${OPENNI2_LIB_DIR}/libOpenNI2.so.0 ${dir}/libOpenNI2.so.0)
  foreach(drv ${HRI_SYNC_STOCK_DRIVERS})
    if(EXISTS ${OPENNI2_LIB_DIR}/OpenNI2/Drivers/lib${drv}.so.0)
      execute_process(COMMAND ${CMAKE_COMMAND} -E create_symlink
        ${OPENNI2_LIB_DIR}/OpenNI2/Drivers/lib${drv}.so.0 ${dir}/OpenNI2/Drivers/lib${drv}.so.0)
    endif()
  endforeach()
endfunction()
hri_sync_openni2_links(${HRI_SYNC_OPENNI2_DEVEL})

include_directories(include ${catkin_INCLUDE_DIRS} ${OPENNI2_INCLUDE_DIR})

# Geometry, rendering, depth tracking and clock mapping: no ROS, no OpenNI.
add_library(hri_sync_tracker_core STATIC
  src/tracker/body.cpp
  src/tracker/render.cpp
  src/tracker/scene.cpp
  src/tracker/depth_tracker.cpp
  src/tracker/joint_filter.cpp
  src/tracker/multi_tracker.cpp
  src/tracker/pose_fit.cpp
  src/tracker/clock_map.cpp)
set_target_properties(hri_sync_tracker_core PROPERTIES POSITION_INDEPENDENT_CODE ON)

# The virtual Kinect driver, built straight into the private Drivers folder.
add_library(VirtualKinect SHARED src/virtual_kinect/virtual_kinect_driver.cpp)
target_link_libraries(VirtualKinect hri_sync_tracker_core Threads::Threads)
set_target_properties(VirtualKinect PROPERTIES
  SOVERSION 0
  LIBRARY_OUTPUT_DIRECTORY ${HRI_SYNC_OPENNI2_DEVEL}/OpenNI2/Drivers)

# OpenNI2 programs: RUNPATH to the private folder so the virtual Kinect loads.
function(hri_sync_openni2_program target)
  add_executable(${target} ${ARGN})
  target_link_libraries(${target} ${OPENNI2_LIBRARY} Threads::Threads)
  set_target_properties(${target} PROPERTIES
    BUILD_RPATH ${HRI_SYNC_OPENNI2_DEVEL}
    INSTALL_RPATH "$ORIGIN/openni2"  # relocatable: HRI_SYNC_OPENNI2_INSTALL beside the program
    RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
  add_dependencies(${target} VirtualKinect)
endfunction()

hri_sync_openni2_program(record_oni src/virtual_kinect/record_oni.cpp)
hri_sync_openni2_program(oni_info src/virtual_kinect/oni_info.cpp)
# The depth noise statistics of a recording or a rendered scene (docs/tracker.md, "Kinect v1 noise").
hri_sync_openni2_program(depth_noise_stats src/virtual_kinect/depth_noise_stats.cpp src/virtual_kinect/oni_clip.cpp)
target_link_libraries(depth_noise_stats hri_sync_tracker_core)
hri_sync_openni2_program(tracker_eval src/tracker/tracker_eval.cpp src/virtual_kinect/oni_clip.cpp)
target_link_libraries(tracker_eval hri_sync_tracker_core)
# Bench: the segmentation stages' CPU cost per frame (installed as tracker_eval is).
add_executable(tracker_stage_cost bench/tracker_stage_cost.cpp)
target_link_libraries(tracker_stage_cost hri_sync_tracker_core)
set_target_properties(tracker_stage_cost PROPERTIES
  RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})

# The ROS node.
hri_sync_openni2_program(skeleton_tracker
  src/tracker/skeleton_tracker_node.cpp
  src/tracker/nite_backend.cpp)
target_link_libraries(skeleton_tracker hri_sync_tracker_core ${catkin_LIBRARIES} ${CMAKE_DL_LIBS})
add_dependencies(skeleton_tracker ${${PROJECT_NAME}_EXPORTED_TARGETS} ${catkin_EXPORTED_TARGETS})

# catkin_lint does not follow the add_executable in hri_sync_openni2_program.
#catkin_lint: ignore_once undefined_target
install(TARGETS skeleton_tracker record_oni oni_info depth_noise_stats tracker_eval tracker_stage_cost
  RUNTIME DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION})
install(TARGETS VirtualKinect
  LIBRARY DESTINATION ${CATKIN_PACKAGE_BIN_DESTINATION}/openni2/OpenNI2/Drivers)
install(CODE "
  file(MAKE_DIRECTORY \$ENV{DESTDIR}${HRI_SYNC_OPENNI2_INSTALL}/OpenNI2/Drivers)
  execute_process(COMMAND ${CMAKE_COMMAND} -E create_symlink
    ${OPENNI2_LIB_DIR}/libOpenNI2.so.0 \$ENV{DESTDIR}${HRI_SYNC_OPENNI2_INSTALL}/libOpenNI2.so.0)
  foreach(drv ${HRI_SYNC_STOCK_DRIVERS})
    execute_process(COMMAND ${CMAKE_COMMAND} -E create_symlink
      ${OPENNI2_LIB_DIR}/OpenNI2/Drivers/lib\${drv}.so.0
      \$ENV{DESTDIR}${HRI_SYNC_OPENNI2_INSTALL}/OpenNI2/Drivers/lib\${drv}.so.0)
  endforeach()")
install(DIRECTORY include/hri_sync/
  DESTINATION ${CATKIN_PACKAGE_INCLUDE_DESTINATION})

if(CATKIN_ENABLE_TESTING)
  # Built with everything (make build), run by test/rostest/tracker_gtest.test in make test.
  catkin_add_gtest(tracker_gtest test/unit/tracker_gtest.cpp)
  target_link_libraries(tracker_gtest hri_sync_tracker_core)
  target_compile_definitions(tracker_gtest PRIVATE HRI_SYNC_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set_target_properties(tracker_gtest PROPERTIES
    RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
  # The realistic virtual Kinect: noise model, scenes, and the driver through OpenNI2
  # (RUNPATH to the private folder so the driver loads). Run by test/rostest/virtual_kinect_gtest.test.
  catkin_add_gtest(virtual_kinect_gtest test/unit/virtual_kinect_gtest.cpp)
  target_link_libraries(virtual_kinect_gtest hri_sync_tracker_core ${OPENNI2_LIBRARY} Threads::Threads)
  target_compile_definitions(virtual_kinect_gtest PRIVATE HRI_SYNC_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set_target_properties(virtual_kinect_gtest PROPERTIES
    BUILD_RPATH ${HRI_SYNC_OPENNI2_DEVEL}
    RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
  # Several users (issue 18 item 3). Run by test/rostest/multi_tracker_gtest.test.
  catkin_add_gtest(multi_tracker_gtest test/unit/multi_tracker_gtest.cpp)
  target_link_libraries(multi_tracker_gtest hri_sync_tracker_core)
  target_compile_definitions(multi_tracker_gtest PRIVATE HRI_SYNC_SOURCE_DIR="${PROJECT_SOURCE_DIR}")
  set_target_properties(multi_tracker_gtest PROPERTIES
    RUNTIME_OUTPUT_DIRECTORY ${CATKIN_DEVEL_PREFIX}/${CATKIN_PACKAGE_BIN_DESTINATION})
  add_custom_target(hri_sync_tracker_tests ALL)
  add_dependencies(hri_sync_tracker_tests tracker_gtest virtual_kinect_gtest multi_tracker_gtest VirtualKinect)
endif()

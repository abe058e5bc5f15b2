# The file readers' fuzz targets: PCD, PLY and KITTI .bin clouds (common/src/cloud_io.cpp, scan.cpp)
# and dataset folders (recordings/src/dataset.cpp, common/src/meta.cpp, text.cpp). Their dictionaries are
# tests/fuzz/NAME.dict.
pl_add_fuzzer(pcd SOURCES fuzz_pcd.cpp LIBS pl_common)
pl_add_fuzzer(ply SOURCES fuzz_ply.cpp LIBS pl_common)
pl_add_fuzzer(kitti_bin SOURCES fuzz_kitti_bin.cpp LIBS pl_common)
pl_add_fuzzer(dataset SOURCES fuzz_dataset.cpp LIBS pl_recordings)
# Recordings (recordings/src/bag_*.cpp) and the ROS messages in them (recordings/src/ros_msgs.cpp).
pl_add_fuzzer(ros1_bag SOURCES fuzz_ros1_bag.cpp LIBS pl_recordings)
pl_add_fuzzer(ros2_bag SOURCES fuzz_ros2_bag.cpp LIBS pl_recordings)
pl_add_fuzzer(mcap SOURCES fuzz_mcap.cpp LIBS pl_recordings)
pl_add_fuzzer(ros_msgs SOURCES fuzz_ros_msgs.cpp LIBS pl_recordings)

target_sources(make_fuzz_seeds PRIVATE ${CMAKE_CURRENT_SOURCE_DIR}/seeds_readers.cpp)
find_package(liblzf CONFIG REQUIRED)  # PCD seeds in binary_compressed
target_link_libraries(make_fuzz_seeds PRIVATE liblzf::liblzf)
# The places of a map version (registration/src/place_index.cpp).
pl_add_fuzzer(places SOURCES fuzz_places.cpp LIBS pl_registration)
target_link_libraries(make_fuzz_seeds PRIVATE pl_registration)
# A vehicle's change report as the map service parses it (schema/src/change_report.cpp).
pl_add_fuzzer(change_report SOURCES fuzz_change_report.cpp LIBS pl_schema pl_common)
# The record of a map's drives that pl-map build --base-map reads (maps/src/drive_record.cpp).
pl_add_fuzzer(drive_record SOURCES fuzz_drive_record.cpp LIBS pl_maps)

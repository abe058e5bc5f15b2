# The LiDAR packet decoders (lidar/src/): one target per vendor. Each input is a run of packets (and a
# calibration file), fed to one decoder.
pl_fuzzed_sources(pl_lidar lidar/src/decoder.cpp)
pl_fuzzed_sources(pl_lidar lidar/src/velodyne.cpp lidar/src/velodyne_calibration.cpp lidar/src/velodyne_clock.cpp lidar/src/velodyne_geometry.cpp lidar/src/velodyne_model.cpp lidar/src/velodyne_sweep.cpp)
pl_add_fuzzer(velodyne_packets SOURCES fuzz_velodyne_packets.cpp LIBS pl_lidar)
pl_fuzzed_sources(pl_lidar lidar/src/hesai.cpp lidar/src/hesai_calibration.cpp lidar/src/hesai_firing.cpp
  lidar/src/hesai_packet.cpp lidar/src/hesai_sweeps.cpp)
pl_add_fuzzer(hesai_packets SOURCES fuzz_hesai_packets.cpp LIBS pl_lidar)
pl_fuzzed_sources(pl_lidar lidar/src/robosense.cpp lidar/src/robosense_calibration.cpp lidar/src/robosense_models.cpp
  lidar/src/robosense_msop.cpp)
pl_add_fuzzer(robosense_packets SOURCES fuzz_robosense_packets.cpp LIBS pl_lidar)
pl_fuzzed_sources(pl_lidar lidar/src/ouster.cpp lidar/src/ouster_metadata.cpp lidar/src/ouster_geometry.cpp)
pl_add_fuzzer(ouster_packets SOURCES fuzz_ouster_packets.cpp LIBS pl_lidar)
# The pcap reader (lidar/include/pl/lidar/pcap.hpp): capture files of any link, damaged or cut short.
pl_fuzzed_sources(pl_lidar lidar/src/pcap.cpp lidar/src/pcap_frames.cpp)
pl_add_fuzzer(pcap SOURCES fuzz_pcap.cpp LIBS pl_lidar)

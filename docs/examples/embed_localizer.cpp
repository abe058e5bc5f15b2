// A vehicle program with PointLocalization embedded: a LiDAR driver thread, a wheel-encoder thread
// a GPS thread and a 100 Hz control loop (see docs/embedding.md). The driver calls are stand-ins for yours.
#include <pl/client/vehicle_localizer.hpp>
#include <pl/common/pose.hpp>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <thread>

// Your drivers (stand-ins here: no vehicle attached).
static bool read_lidar(double& t, pl::Scan& scan) { (void)t, (void)scan; return false; }
static bool read_encoders(double& t, double& left_m, double& right_m) { (void)t, (void)left_m, (void)right_m; return false; }
static bool read_gps(double& t, Eigen::Vector3d& enu) { (void)t, (void)enu; return false; }  // map frame (pl::EnuFrame)
static double clock_now() { return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: embed_localizer SERVER_URL MAP\n");
    return 2;
  }
  pl::client::VehicleLocalizerConfig cfg;
  cfg.tiles.server = argv[1];                                             // pl-server
  cfg.tiles.map = argv[2];
  cfg.tiles.cache_path = "/var/cache/pl/tiles.sqlite";                    // drives on with the server down
  cfg.localizer.scan.beams = 16;                                          // of the sensor's 64
  cfg.base_from_lidar = pl::make_pose(1.2, 0.0, 1.9, 0.0, 0.0, 0.0);      // LiDAR mount on the base
  cfg.base_from_antenna = Eigen::Vector3d(-0.4, 0.0, 1.6);                // GPS antenna
  cfg.wheel_base_m = 1.6;
  cfg.start_from_gps = true;                                              // or loc.start(pose, t)
  pl::client::VehicleLocalizer loc(cfg);

  std::atomic<bool> running{true};
  std::thread lidar([&] {
    double t;
    pl::Scan scan;
    while (running && read_lidar(t, scan)) loc.add_scan(t, scan);      // rings: pl::rings_from_azimuth(scan)
  });
  std::thread wheels([&] {
    double t, left, right;
    while (running && read_encoders(t, left, right)) loc.add_wheel_travel(t, left, right);
  });
  std::thread gps([&] {
    double t;
    Eigen::Vector3d antenna;
    while (running && read_gps(t, antenna)) loc.add_gps(t, antenna);
  });
  // The control loop: the fused pose at 100 Hz, with its health; act on Lost.
  for (int i = 0; i < 100; ++i) {
    const pl::client::PoseEstimate p = loc.pose_at(clock_now());
    if (p.valid && p.health != pl::client::Health::Ok) std::fprintf(stderr, "localization %s: %s\n", pl::client::health_name(p.health), p.note.c_str());
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  running = false;
  lidar.join();
  wheels.join();
  gps.join();
  return 0;
}

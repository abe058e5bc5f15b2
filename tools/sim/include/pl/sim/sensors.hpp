// Wheel encoders and GPS along the simulated drive.
#pragma once

#include <random>
#include <string>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/sim/trajectory.hpp"
#include "pl/sim/world.hpp"

namespace pl::sim {

// Differential-drive wheel encoders, read at `rate_hz`. The LiDAR sits above the middle of the axle.
struct EncoderConfig {
  double rate_hz = 100.0;
  double wheel_base = 1.6;     // metres between the wheels
  double wheel_radius = 0.30;  // metres
  int teeth = 36;              // teeth of the encoder gear on each wheel
  int edges_per_tooth = 4;     // quadrature decoding: 4 counts a tooth -> 144 counts a turn (1.3 cm)
  double scale_left = 1.003;   // wheel-size errors: reported / true travel (mostly common,
  double scale_right = 1.0025;  // a 0.05 % difference turns the heading ~1.8 deg per 100 m)
  double slip = 0.0015;  // extra outer-wheel travel per m/s^2 of lateral acceleration, as a share
};
// Cumulative travel of each wheel as the vehicle would report it (quantized to counts).
std::vector<EncoderSample> simulate_encoder(const SimTrajectory& path, double t0, double t1, const EncoderConfig& cfg);
double encoder_resolution(const EncoderConfig& cfg);  // metres a count

// One record of a real receiver's log, replayed along the route (e.g. from KITTI's OXTS files).
struct GnssProfileEntry {
  double std_m;
  int status;
  int satellites;
};
// Reads `DIR/oxts/data/*.txt` (or `DIR/data/*.txt`): pos_accuracy, position mode, satellites.
std::vector<GnssProfileEntry> read_gnss_profile(const std::string& dir);

struct GpsConfig {
  double rate_hz = 10.0;
  double time_offset = 0.05;  // GPS epochs fall between the scans
  Eigen::Vector3d lever_arm = Eigen::Vector3d(-0.5, 0.0, 0.25);  // antenna in the LiDAR frame
  double sigma_fixed = 0.02, sigma_float = 0.25, sigma_single = 1.5;
  double multipath_rate = 0.04;  // chance a fix starts a multipath burst, where the sky is blocked
  std::vector<GnssProfileEntry> profile;  // when set, replayed by time at 10 Hz
};

// GPS fixes of the antenna. The sky blocked by buildings degrades the status (rtk-fixed -> float
// -> single -> outage) and brings multipath outliers of metres while the receiver still reports
// its usual sigma. Positions go through `enu` into lat/lon/alt.
std::vector<GpsFix> simulate_gps(const SimTrajectory& path, double t0, double t1, const World& world, const EnuFrame& enu,
                                 const GpsConfig& cfg, std::mt19937_64& rng);

// The ground truth as a real drive's is: a GNSS/INS's estimate, not the pose the scans were taken
// from. KITTI's is an OXTS RT3003's; on drive 0005, against the LiDAR's own odometry, it wanders in
// height by up to 0.4 m over three seconds (the street is flat), runs 3 % short along the track (its
// own velocity, integrated, agrees with the LiDAR), and jitters by a couple of centimetres from one
// scan to the next (docs/benchmarks.md). The errors, in the vehicle frame, times `scale`: along the
// track 1.5 % short of the distance travelled since the first scan (half drive 0005's: with all 3 %
// the simulated APE was 1.6 times the real one; meant for drives of that length, not kilometres),
// plus a smooth wander (standard deviation, time constant) of 0.2 m over 10 s and a white jitter of
// 2 cm; across it 5 cm over 5 s; in height 0.1 m over 2 s; heading 0.03 deg over 5 s; and a white
// attitude noise of 0.015 deg about each axis. Sized so that pl-sim driving drive 0005's trajectory
// gives the real drive's scan-to-scan errors and APE on the paper's protocol within 30 %
// (bench/sim_vs_real.sh; 0.6 m along and 0.2 m in height gave 1.7 times the real APE). A map built
// at these poses is layered as the street's is.
struct TruthErrorConfig {
  double scale = 0.0;  // 0: the exact poses
  double along_share = -0.015, along_m = 0.2, along_s = 10.0, jitter_m = 0.02;
  double across_m = 0.05, across_s = 5.0;
  double height_m = 0.1, height_s = 2.0;
  double heading_deg = 0.03, heading_s = 5.0;
  double attitude_jitter_deg = 0.015;  // white, about each axis
};
// The poses of `truth` (at `times`, in order) as the INS would report them.
std::vector<Pose, Eigen::aligned_allocator<Pose>> ins_truth(const std::vector<Pose, Eigen::aligned_allocator<Pose>>& truth,
                                                          const std::vector<double>& times, const TruthErrorConfig& cfg,
                                                          std::uint64_t seed);

// Share of the sky's azimuths (36 sectors) where buildings or trees rise above 40 degrees, seen from p.
double sky_blockage(const World& world, const Eigen::Vector2f& p);

}  // namespace pl::sim

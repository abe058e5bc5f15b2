// A localization run as an MCAP file that Foxglove opens with no plugin (`pl-localize --log run.mcap`):
// JSON messages on Foxglove's well-known schemas (JSON Schema documents written here), plus one
// schema of our own for the per-scan report. docs/run-logs.md says what each channel holds.
//
//   channel   schema                   when                           what
//   /pose     foxglove.PoseInFrame     every fused pose (the output)  the base in frame "map"
//   /tf       foxglove.FrameTransform  with every /pose               map -> base, for the 3D panel to follow
//   /scan     foxglove.PointCloud      every scan                     the scan placed by its fused pose, "map"
//   /map      foxglove.PointCloud      when the ROI's tiles change    the tiles the scans register against
//   /gps      foxglove.LocationFix     every fix of the drive         latitude, longitude, altitude as received
//   /health   pl.ScanReport            every scan                     health, note, protection level, ICP, timings
//
// Decisions:
// - Times: a message's log_time is the drive's own clock in nanoseconds (absolute for recordings and
//   KITTI raw drives), and its JSON `timestamp` the same instant as {sec, nsec}. Each channel's
//   messages are written in time order.
// - Point clouds are in the map frame (ENU metres about the map's origin) as float32 x, y, z (12 bytes
//   a point, no intensity), `data` base64 as Foxglove's JSON encoding has bytes. Both are thinned so
//   that a log stays small: /scan is the localizer's own preparation of the scan (beams, field of
//   view, range) on a scan_voxel_m grid, twice as fine as the registration's 1 m; /map keeps the
//   first point of each map_voxel_m voxel of each tile, and is written only when the set of tiles
//   (or a tile's content) changes: Foxglove shows a topic's newest message, so each holds the ROI.
// - /scan is placed by the pose of the LiDAR the localizer reports for the scan (ScanReport::fused;
//   the base's pose times base_from_lidar); its points are not corrected for the motion during the
//   sweep (the registered ones were, when deskewing was on).
// - /gps: the drive's GPS fixes are geodetic already (GpsFix::position): written as received, with
//   the reported horizontal sigma as a diagonal covariance (vertical: twice it, so the type is
//   APPROXIMATED); fixes with no position (status none) are left out. No map origin is needed.
// - Logging never feeds back into localization: the caller hands over copies of what the localizer
//   reported (a run with and without a log gives the same poses).
// - Errors (disk full) are pl::Error naming the file, from the call that hit them or from close().
#pragma once

#include <Eigen/Geometry>

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "pl/client/localizer.hpp"
#include "pl/client/map_tile.hpp"
#include "pl/common/scan.hpp"
#include "pl/recordings/dataset.hpp"
#include "pl/recordings/mcap_writer.hpp"

namespace pl::client {

struct RunLogOptions {
  // The localizer's scan preparation (beams kept, field of view, range): /scan shows those points.
  // Its voxel_m is replaced by scan_voxel_m.
  ScanPrepConfig scan;
  // pl-sim's town, 16 of 64 beams: ~3,600 points a scan at 0.5 m (43 KB, 58 KB as JSON with base64;
  // zstd takes off about a third); ~5,800 at 0.3 m. The ROI's tiles (0.2 m map voxels): ~33,000
  // points at 0.5 m.
  double scan_voxel_m = 0.5;
  double map_voxel_m = 0.5;
  std::string map_frame = "map", base_frame = "base";
  McapWriterOptions mcap;     // zstd chunks of 1 MiB by default
};

class RunLog {
 public:
  // Creates the file and writes the schemas and channels. Throws pl::Error naming the path.
  RunLog(const std::string& path, const RunLogOptions& options = {});
  ~RunLog();  // closes the file if close() was not called (errors then go unreported)
  RunLog(const RunLog&) = delete;
  RunLog& operator=(const RunLog&) = delete;

  // A fused pose of the base (what the run outputs): /pose and /tf.
  void pose(double t, const Eigen::Isometry3d& base_in_map);
  // A scan as registered: /scan (points in the LiDAR frame, their rings when beams are chosen,
  // placed by report.fused, the LiDAR's pose) and /health (the report; total_ms: the whole scan's
  // wall time as the caller measured it, < 0 when not known).
  void scan(const ScanReport& report, const Scan& points, const std::vector<std::uint16_t>& rings, double total_ms = -1);
  // The ROI map's tiles after a scan at t: /map when they differ from the last written.
  void map(double t, const std::vector<MapTile>& tiles);
  // A GPS fix: /gps.
  void gps(const GpsFix& fix);
  // Writes the summary and closes the file; throws pl::Error when it could not be written.
  void close();

  const std::string& path() const { return writer_.path(); }
  // Messages written per topic ("/pose" -> n), and the file's bytes so far.
  const std::map<std::string, std::uint64_t>& counts() const { return counts_; }
  std::uint64_t bytes() const { return writer_.bytes_written(); }

 private:
  RunLogOptions o_;
  McapWriter writer_;
  std::uint16_t pose_ = 0, tf_ = 0, scan_ = 0, map_ = 0, gps_ = 0, health_ = 0;
  std::map<std::string, std::uint64_t> counts_;
  std::map<std::uint16_t, std::uint32_t> sequence_;
  std::vector<std::pair<TileKey, std::string>> map_written_;  // the tiles of the last /map
  bool map_any_ = false;

  void put(std::uint16_t channel, const std::string& topic, double t, const std::string& json);
};

}  // namespace pl::client

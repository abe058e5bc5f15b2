#include "pl/dataset/info.hpp"

#include <algorithm>
#include <cstdarg>
#include <cstdio>
#include <map>

#include "median.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/scan.hpp"
#include "pl/common/voxel.hpp"

namespace pl::dataset {

namespace {


}  // namespace

nlohmann::json dataset_info(const Dataset& ds, const InfoConfig& cfg, const std::function<void(std::size_t, std::size_t)>& progress) {
  if (cfg.sample < 1) throw Error("--sample must be at least 1");
  nlohmann::json j;
  j["dir"] = ds.dir;
  j["layout"] = ds.layout_name();
  j["scans"] = ds.size();
  j["first_frame"] = ds.frame_ids.front();
  j["last_frame"] = ds.frame_ids.back();
  const double duration = ds.times.back() - ds.times.front();
  j["duration_s"] = duration;
  // Frames may be a sample of a longer drive (e.g. KITTI 00 frames 0-9, 94, 95, ...): rate from frame numbers.
  j["rate_hz"] = ds.size() > 1 && duration > 0 ? static_cast<double>(ds.frame_ids.back() - ds.frame_ids.front()) / duration : 0.0;

  // Per-scan figures from evenly spaced scans.
  const std::size_t count = std::min<std::size_t>(ds.size(), cfg.sample);
  std::vector<double> points, rings, kept16, voxel02;
  for (std::size_t k = 0; k < count; ++k) {
    const std::size_t i = count == 1 ? 0 : k * (ds.size() - 1) / (count - 1);
    const Frame frame = ds.load_frame(i);
    const Scan& scan = frame.scan;
    const auto& r = frame.rings;
    points.push_back(static_cast<double>(scan.size()));
    rings.push_back(r.empty() ? 0.0 : 1.0 + *std::max_element(r.begin(), r.end()));
    const int every = std::max(1, ds.meta.sensor.beams / 16);
    if (!scan.empty()) {
      kept16.push_back(static_cast<double>(keep_every_kth_ring(scan, r, every).size()) / static_cast<double>(scan.size()));
      voxel02.push_back(static_cast<double>(voxel_downsample(scan, 0.2).size()));
    }
    if (progress) progress(k + 1, count);
  }
  j["sampled_scans"] = count;
  j["points_per_scan"] = {{"min", *std::min_element(points.begin(), points.end())},
                          {"median", median_of(points)},
                          {"max", *std::max_element(points.begin(), points.end())}};
  j["beams"] = {{"sensor", ds.meta.sensor.model},
                {"table", ds.meta.sensor.beams},
                {"rings_found_median", median_of(rings)},
                {"rings_found_min", *std::min_element(rings.begin(), rings.end())},
                {"rings_found_max", *std::max_element(rings.begin(), rings.end())},
                {"ring_method", ds.recording ? (rings.empty() || rings.front() == 0 ? "none (no ring field)" : "the clouds' ring field")
                                : ds.meta.sensor.point_order == "laser-by-laser" ? "azimuth wrap" : "vertical angle table"},
                {"sixteen_beam_share_median", median_of(kept16)},
                {"voxel_0.2m_points_median", median_of(voxel02)}};

  if (ds.has_ground_truth()) {
    double length = 0;
    for (std::size_t i = 1; i < ds.ground_truth.size(); ++i)
      length += (ds.ground_truth.poses[i].translation() - ds.ground_truth.poses[i - 1].translation()).norm();
    j["ground_truth"] = {{"poses", ds.ground_truth.size()}, {"path_length_m", length}};
  } else {
    j["ground_truth"] = nullptr;
  }
  if (!ds.gps.empty()) {
    std::map<std::string, std::size_t> mix;
    std::vector<double> stds;
    for (const auto& f : ds.gps) {
      ++mix[gps_status_name(f.status)];
      stds.push_back(f.std_m);
    }
    j["gps"] = {{"fixes", ds.gps.size()}, {"status", mix}, {"std_m_median", median_of(stds)}};
  } else {
    j["gps"] = nullptr;
  }
  j["encoder_samples"] = ds.encoder.size();
  j["odometry_samples"] = ds.odometry.size();
  j["sidecars"] = ds.sidecars;
  if (ds.meta.origin) j["origin"] = {{"lat", ds.meta.origin->lat_deg}, {"lon", ds.meta.origin->lon_deg}, {"alt", ds.meta.origin->alt_m}};
  if (ds.recording) {
    const RecordingInfo& ri = ds.recording_info;
    nlohmann::json topics = nlohmann::json::array();
    for (const auto& t : ri.topics)
      topics.push_back({{"name", t.name}, {"type", t.type}, {"encoding", t.encoding}, {"messages", t.count}, {"first_s", t.first_s},
                        {"last_s", t.last_s}, {"rate_hz", t.rate_hz}, {"max_gap_s", t.max_gap_s}, {"frame_id", t.frame_id}, {"use", t.use}});
    j["recording"] = {{"format", ri.format}, {"topics", topics}, {"lidar_frame", ri.lidar_frame}, {"base_frame", ri.base_frame},
                      {"gps_frame", ri.gps_frame}, {"point_times", ds.has_point_times()},
                      {"gps_lever_arm_m", {ds.meta.vehicle.gps_lever_arm.x(), ds.meta.vehicle.gps_lever_arm.y(), ds.meta.vehicle.gps_lever_arm.z()}},
                      {"notes", ri.notes}};
    if (!ri.lidar.empty()) j["recording"]["lidar_packets"] = ri.lidar;
  }
  return j;
}

std::string dataset_info_text(const Dataset& ds, const nlohmann::json& j) {
  const auto& pts = j["points_per_scan"];
  const auto& beams = j["beams"];
  std::string out;
  append_format(out, "dataset        %s\n", ds.dir.c_str());
  append_format(out, "layout         %s\n", ds.layout_name());
  append_format(out, "scans          %zu (frames %ld..%ld), %.1f s at %.2f Hz\n", ds.size(), ds.frame_ids.front(), ds.frame_ids.back(),
         j["duration_s"].get<double>(), j["rate_hz"].get<double>());
  append_format(out, "points/scan    min %.0f, median %.0f, max %.0f (%zu scans read)\n", pts["min"].get<double>(), pts["median"].get<double>(),
         pts["max"].get<double>(), j["sampled_scans"].get<std::size_t>());
  append_format(out, "beams          %s, %d in the table; rings found per scan: median %.0f (min %.0f, max %.0f) by %s\n",
         ds.meta.sensor.model.c_str(), ds.meta.sensor.beams, beams["rings_found_median"].get<double>(),
         beams["rings_found_min"].get<double>(), beams["rings_found_max"].get<double>(), beams["ring_method"].get<std::string>().c_str());
  append_format(out, "16 beams       keep %.1f %% of the points; 0.2 m voxels leave %.0f points a scan (medians)\n",
         100.0 * beams["sixteen_beam_share_median"].get<double>(), beams["voxel_0.2m_points_median"].get<double>());
  if (ds.has_ground_truth())
    append_format(out, "ground truth   %zu poses, path length %.1f m\n", ds.ground_truth.size(), j["ground_truth"]["path_length_m"].get<double>());
  else
    append_format(out, ds.recording ? "ground truth   none (name a topic with --truth-topic)\n" : "ground truth   none (no poses.txt)\n");
  if (!ds.gps.empty()) {
    append_format(out, "gps            %zu fixes, median std %.3f m:", ds.gps.size(), j["gps"]["std_m_median"].get<double>());
    for (const auto& [name, n] : j["gps"]["status"].items())
      append_format(out, " %s %.1f %%", name.c_str(), 100.0 * n.get<double>() / static_cast<double>(ds.gps.size()));
    append_format(out, "\n");
  } else {
    append_format(out, "gps            none\n");
  }
  if (!ds.encoder.empty()) append_format(out, "encoder        %zu samples\n", ds.encoder.size());
  if (!ds.odometry.empty()) append_format(out, "odometry       %zu samples\n", ds.odometry.size());
  std::string side;
  for (const auto& s : ds.sidecars) side += (side.empty() ? "" : ", ") + s;
  append_format(out, "sidecars       %s\n", side.empty() ? "none" : side.c_str());
  if (ds.meta.origin)
    append_format(out, "origin         lat %.9f, lon %.9f, alt %.3f m\n", ds.meta.origin->lat_deg, ds.meta.origin->lon_deg, ds.meta.origin->alt_m);
  if (ds.recording) {
    const RecordingInfo& ri = ds.recording_info;
    append_format(out, "recording      %s, %zu topics (scans from %s)\n", ri.format.c_str(), ri.topics.size(),
                  ri.lidar.empty() ? "the clouds' header stamps, the recording's clock" : "the LiDAR's packets, at their first firing");
    if (!ri.lidar.empty()) append_format(out, "lidar packets  %s\n", ri.lidar.c_str());
    for (const auto& t : ri.topics) {
      append_format(out, "  %-28s %-26s %-4s %6zu msgs", t.name.c_str(), t.type.c_str(), t.encoding.c_str(), t.count);
      if (t.count > 1) append_format(out, " %7.2f Hz, max gap %.3f s", t.rate_hz, t.max_gap_s);
      if (!t.frame_id.empty()) append_format(out, ", frame %s", t.frame_id.c_str());
      append_format(out, "%s\n", t.use.empty() ? "" : ("  -> " + t.use).c_str());
    }
    append_format(out, "frames         LiDAR %s, base %s, GPS antenna %s; lever arm in the LiDAR frame %.3f %.3f %.3f m\n",
                  ri.lidar_frame.empty() ? "-" : ri.lidar_frame.c_str(), ri.base_frame.empty() ? "-" : ri.base_frame.c_str(),
                  ri.gps_frame.empty() ? "-" : ri.gps_frame.c_str(), ds.meta.vehicle.gps_lever_arm.x(), ds.meta.vehicle.gps_lever_arm.y(),
                  ds.meta.vehicle.gps_lever_arm.z());
    append_format(out, "localizer      scans from %s%s; odometry %s; GPS %s\n",
                  ri.topics.empty() ? "-" : [&] { for (const auto& t : ri.topics) if (t.use == "scans") return t.name.c_str(); return "-"; }(),
                  ds.has_point_times() ? " with per-point times" : "", ds.odometry.empty() ? "none (LiDAR odometry)" : "from the odometry topic",
                  ds.gps.empty() ? "none" : "from the NavSatFix topic");
    if (!ri.point_times.empty()) append_format(out, "point times    %s\n", ri.point_times.c_str());
    for (const auto& n : ri.notes) append_format(out, "note           %s\n", n.c_str());
  }
  return out;
}

}  // namespace pl::dataset

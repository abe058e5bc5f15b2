// A recording as a dataset: the point-cloud topic's messages are the scans (at their header stamps,
// the recording's own clock, kept absolute), or a LiDAR's packet topic's sweeps (dataset_packets.cpp,
// at their first firing), the odometry topic gives odometry poses of the LiDAR,
// the NavSatFix topic GPS fixes in an ENU frame at the first fix, and /tf_static the extrinsics that
// tie the three frames together (the GPS antenna's lever arm in the LiDAR frame).
#include "dataset_recording.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <mutex>
#include <optional>

#include "packet_scans.hpp"
#include "pl/common/error.hpp"
#include "pl/common/scan.hpp"
#include "pl/common/text.hpp"
#include "pl/lidar/beam_table.hpp"
#include "pl/recordings/bag.hpp"
#include "pl/recordings/packet_msgs.hpp"
#include "pl/recordings/ros_msgs.hpp"

namespace pl {

RecordingScans::~RecordingScans() = default;

namespace {

ros::PointCloud recording_cloud(RecordingScans& rec, std::size_t i) {
  if (i >= rec.scans.size())
    throw Error("scan index " + std::to_string(i) + " out of range (" + rec.path + " has " + std::to_string(rec.scans.size()) + " scans)");
  std::lock_guard<std::mutex> lock(rec.mutex);
  const std::string name = rec.path + ": " + rec.topic + " message " + std::to_string(i);
  return ros::decode_point_cloud2(rec.reader->read(rec.scans[i]), rec.encoding, name, rec.sweep);
}

}  // namespace

Frame recording_frame(RecordingScans& rec, std::size_t i, bool with_rings) {
  if (rec.packets) {
    std::lock_guard<std::mutex> lock(rec.mutex);
    Frame f = rec.packets->frame(i);
    if (!with_rings) f.rings.clear();
    return f;
  }
  ros::PointCloud cloud = recording_cloud(rec, i);
  Frame f;
  f.scan = std::move(cloud.points);
  if (with_rings && cloud.rings.empty() && rec.rings_from_order)
    f.rings = rings_from_azimuth(f.scan);
  else if (with_rings && cloud.rings.empty() && !rec.beam_table.empty())
    f.rings = rings_from_elevation(f.scan, rec.beam_table);
  else if (with_rings)
    f.rings = std::move(cloud.rings);
  f.times = std::move(cloud.times);
  return f;
}

namespace {

const char* encoding_name(bag::Encoding e) { return e == bag::Encoding::Cdr ? "cdr" : "ros1"; }

// The topic of `type` to use: the one named, else the only one; none found is not an error here.
const bag::Topic* choose(const bag::Reader& r, const std::string& type, const std::string& named, const char* flag, std::uint32_t& index) {
  std::vector<std::uint32_t> of_type;
  for (std::uint32_t k = 0; k < r.topics().size(); ++k)
    if (r.topics()[k].type == type) of_type.push_back(k);
  if (!named.empty()) {
    for (std::uint32_t k = 0; k < r.topics().size(); ++k)
      if (r.topics()[k].name == named) {
        if (r.topics()[k].type != type)
          throw Error(r.path() + ": " + flag + " " + named + " is a " + r.topics()[k].type + " topic; it must be a " + type);
        index = k;
        return &r.topics()[k];
      }
    std::string have;
    for (std::uint32_t k : of_type) have += " " + r.topics()[k].name;
    throw Error(r.path() + ": no topic " + named + " (" + flag + "); its " + type + " topics:" + (have.empty() ? " none" : have));
  }
  if (of_type.empty()) return nullptr;
  if (of_type.size() > 1) {
    std::string have;
    for (std::uint32_t k : of_type) have += " " + r.topics()[k].name;
    throw Error(r.path() + ": several " + type + " topics:" + have + "; choose one with " + flag);
  }
  index = of_type.front();
  return &r.topics()[index];
}


// Frames of /tf_static as poses in their tree's root.
class StaticTree {
 public:
  void add(const ros::Transform& t) { parent_[t.child_frame_id] = {t.header.frame_id, t.pose}; }
  // The pose of frame `to` in frame `from`, when both hang in one tree (identity when they are the same).
  std::optional<Pose> between(const std::string& from, const std::string& to) const {
    if (from == to) return Pose::Identity();
    std::string ra, rb;
    const Pose a = in_root(from, ra), b = in_root(to, rb);
    if (ra != rb) return std::nullopt;
    return Pose(a.inverse() * b);
  }

 private:
  std::map<std::string, std::pair<std::string, Pose>> parent_;
  Pose in_root(std::string frame, std::string& root) const {
    Pose p = Pose::Identity();
    for (std::size_t depth = 0; depth < 64; ++depth) {  // a loop in a damaged tree ends here
      auto it = parent_.find(frame);
      if (it == parent_.end()) break;
      p = it->second.second * p;
      frame = it->second.first;
    }
    root = frame;
    return p;
  }
};

// A ring-less cloud in any point order: its rings from its points' elevations, against the beam table
// of the model named (--lidar-model) or of the one model whose table the first scan fits.
void rings_from_elevation_table(RecordingScans& rec, const Scan& first, int turns, const std::string& model, int& beams, Dataset& ds) {
  RecordingInfo& info = ds.recording_info;
  const std::string why = "the clouds have no ring field, and their points do not come laser by laser (" + std::to_string(turns) +
                          " turns of azimuth in the first scan, not 16, 32, 40, 64 or 128)";
  std::vector<const lidar::BeamTable*> candidates;
  if (!model.empty()) {
    const lidar::BeamTable* t = lidar::nominal_beam_table(model);
    if (!t) {
      std::string known;
      for (const auto& table : lidar::nominal_beam_tables())
        for (const auto& m : table.models) known += (known.empty() ? "" : ", ") + m;
      info.notes.push_back(why + "; --lidar-model " + model + " has no fixed beam table (those that have: " + known + "): no beams can be chosen");
      return;
    }
    candidates.push_back(t);
  }
  const lidar::BeamTable* t = lidar::find_beam_table(first, candidates);
  if (!t) {
    info.notes.push_back(why + ", and their elevations fit " + (model.empty() ? "no known sensor's beams" : "the beams of a " + model) +
                         ": no beams can be chosen (name the sensor with --lidar-model, or record the driver's ring field)");
    return;
  }
  rec.beam_table = t->elevation_deg;
  beams = static_cast<int>(t->elevation_deg.size());
  ds.meta.sensor.vertical_angles_deg = t->elevation_deg;
  std::string models;
  for (const auto& m : t->models) models += (models.empty() ? "" : "/") + m;
  info.notes.push_back(format_text("the clouds have no ring field: rings from the points' elevations against the %s beam table (%.1f %% of "
                                   "the first scan's points within 0.25 degrees of a beam)",
                                   models.c_str(), 100.0 * lidar::fit_beams(first, t->elevation_deg).share));
}

struct Stamped {
  std::int64_t stamp;
  bag::MessageRef ref;
};

// The scans of a PointCloud2 topic in stamp order, and what the first cloud tells of the sensor: its
// rings and whether its points carry times.
void describe_clouds(RecordingScans& rec, std::vector<Stamped> scans, const std::string& topic, const std::string& model, Dataset& ds) {
  RecordingInfo& info = ds.recording_info;
  if (scans.empty()) throw Error(rec.path + ": " + topic + " has no messages, so no scans");
  std::stable_sort(scans.begin(), scans.end(), [](const Stamped& a, const Stamped& b) { return a.stamp < b.stamp; });
  for (std::size_t i = 0; i < scans.size(); ++i) {
    rec.scans.push_back(scans[i].ref);
    ds.times.push_back(ns_to_seconds(scans[i].stamp));
    ds.frame_ids.push_back(static_cast<long>(i));
  }

  // The scans' rate bounds the spread their per-point times may have.
  if (ds.times.size() > 1) ds.meta.sensor.rate_hz = (ds.times.size() - 1) / std::max(1e-9, ds.times.back() - ds.times.front());
  if (ds.meta.sensor.rate_hz > 0) rec.sweep = ros::SweepBounds::around(1.0 / ds.meta.sensor.rate_hz);

  // The first scan tells the sensor: its rings and whether its points carry times.
  const ros::PointCloud first = recording_cloud(rec, 0);
  int beams = 0;
  for (std::uint16_t ring : first.rings) beams = std::max(beams, ring + 1);
  ds.meta.sensor.model = "from " + topic;
  ds.meta.sensor.point_order = "any";
  ds.meta.sensor.vertical_angles_deg.clear();
  if (first.rings.empty() && !first.points.empty()) {
    // No ring field: where the points come laser by laser (each ring one turn of azimuth, as a KITTI
    // folder's), the turns are the rings; trusted only when they count a sensor's beams.
    const std::vector<std::uint16_t> turns = rings_from_azimuth(first.points);
    const int n = turns.back() + 1;
    if (n == 16 || n == 32 || n == 40 || n == 64 || n == 128) {
      rec.rings_from_order = true;
      beams = n;
      ds.meta.sensor.point_order = "laser-by-laser";
      info.notes.push_back("the clouds have no ring field: rings from the points' order, laser by laser (" + std::to_string(n) +
                           " turns of azimuth in the first scan)");
    } else {
      rings_from_elevation_table(rec, first.points, n, model, beams, ds);
    }
  }
  ds.meta.sensor.beams = beams > 0 ? beams : 1;
  ds.point_times_in_clouds = !first.times.empty();
  if (ds.point_times_in_clouds) {
    info.point_times = format_text("field %s, %s, spanning %.3f s of the first scan", first.time_field.c_str(), first.time_unit.c_str(),
                                   first.time_span_s);
  } else if (!first.time_set_aside.empty()) {
    info.point_times = first.time_set_aside;
    info.notes.push_back("no per-point times: a sweep is timed by its points' azimuths");
  } else {
    info.notes.push_back("the clouds have no per-point time field: a sweep is timed by its points' azimuths");
  }
}

}  // namespace

Dataset open_recording(const std::string& path, const DatasetOptions& options) {
  auto rec = std::make_shared<RecordingScans>();
  rec->reader = bag::open(path);
  rec->path = path;
  bag::Reader& r = *rec->reader;
  Dataset ds;
  ds.dir = path;
  ds.layout = DatasetLayout::Recording;
  RecordingInfo& info = ds.recording_info;
  info.format = r.format();

  std::uint32_t pi = 0, oi = 0, gi = 0, ti = 0;
  const bag::Topic* points = choose_packet_topic(r, options, pi);
  const bool packets = points != nullptr;
  if (!packets) points = choose(r, "sensor_msgs/PointCloud2", options.points_topic, "--points-topic", pi);
  const bag::Topic* truth = options.truth_topic.empty() ? nullptr : choose(r, "nav_msgs/Odometry", options.truth_topic, "--truth-topic", ti);
  const bag::Topic* odom = nullptr;
  if (!options.odom_topic.empty() || !truth) {
    odom = choose(r, "nav_msgs/Odometry", options.odom_topic, "--odom-topic", oi);
  } else {  // the odometry: the one Odometry topic besides the truth, if there is one
    std::vector<std::uint32_t> others;
    for (std::uint32_t k = 0; k < r.topics().size(); ++k)
      if (k != ti && r.topics()[k].type == "nav_msgs/Odometry") others.push_back(k);
    if (others.size() > 1) throw Error(path + ": several nav_msgs/Odometry topics besides the truth; choose one with --odom-topic");
    if (others.size() == 1) odom = &r.topics()[oi = others.front()];
  }
  if (odom && truth && oi == ti) throw Error(path + ": " + truth->name + " cannot be both the odometry and the truth");
  const bag::Topic* gps = choose(r, "sensor_msgs/NavSatFix", options.gps_topic, "--gps-topic", gi);
  if (!points) {
    std::string seen;
    for (const bag::Topic& t : r.topics()) seen += "\n  " + t.name + " (" + t.type + ", " + std::to_string(t.count) + " messages)";
    throw Error(path + ": no sensor_msgs/PointCloud2 topic and no LiDAR packet topic, so no scans; the " + r.format() + " has " +
                (seen.empty() ? std::string("no topics") : "these topics:" + seen));
  }
  rec->topic = points->name;
  rec->encoding = points->encoding;

  // One pass over the messages: the scans' stamps, odometry, fixes and static transforms.
  std::vector<Stamped> scans;
  std::vector<ros::Odometry, Eigen::aligned_allocator<ros::Odometry>> odo, gt;
  std::vector<ros::NavSatFix> fixes;
  StaticTree tree;
  std::vector<std::vector<double>> topic_times(r.topics().size());
  std::vector<std::string> topic_frames(r.topics().size());
  for (const bag::MessageRef& m : r.messages()) {
    const bag::Topic& t = r.topics()[m.topic];
    topic_times[m.topic].push_back(ns_to_seconds(m.time_ns));
    const std::string name = path + ": " + t.name + " message at " + std::to_string(ns_to_seconds(m.time_ns)) + " s";
    if (m.topic == pi && packets) {
      if (topic_frames[m.topic].empty() && t.type.find("PacketMsg") == std::string::npos)
        topic_frames[m.topic] = ros::decode_header(r.read(m), t.encoding, name).frame_id;
    } else if (m.topic == pi) {
      // Only the header: the points are decoded when the scan is loaded.
      const std::string_view bytes = r.read(m);
      ros::Header h = ros::decode_header(bytes, t.encoding, name);
      if (topic_frames[m.topic].empty()) topic_frames[m.topic] = h.frame_id;
      scans.push_back({h.stamp_ns != 0 ? h.stamp_ns : m.time_ns, m});
    } else if (odom && m.topic == oi) {
      odo.push_back(ros::decode_odometry(r.read(m), t.encoding, name));
      if (topic_frames[m.topic].empty()) topic_frames[m.topic] = odo.back().header.frame_id;
    } else if (truth && m.topic == ti) {
      gt.push_back(ros::decode_odometry(r.read(m), t.encoding, name));
      if (topic_frames[m.topic].empty()) topic_frames[m.topic] = gt.back().header.frame_id;
    } else if (gps && m.topic == gi) {
      fixes.push_back(ros::decode_nav_sat_fix(r.read(m), t.encoding, name));
      if (topic_frames[m.topic].empty()) topic_frames[m.topic] = fixes.back().header.frame_id;
    } else if (t.type == "tf2_msgs/TFMessage" && (t.name == "/tf_static" || t.name == "tf_static")) {
      for (const ros::Transform& x : ros::decode_tf_message(r.read(m), t.encoding, name)) {
        ros::Transform y = x;
        y.header.frame_id = ros::frame_name(y.header.frame_id);
        y.child_frame_id = ros::frame_name(y.child_frame_id);
        tree.add(y);
      }
    }
  }
  info.lidar_frame = ros::frame_name(topic_frames[pi]);
  if (packets) {
    rec->packets = open_packet_scans(r, pi, options);
    describe_packet_sensor(*rec->packets, ds);
    for (std::size_t i = 0; i < rec->packets->size(); ++i) {
      ds.times.push_back(ns_to_seconds(rec->packets->stamp_ns(i)));
      ds.frame_ids.push_back(static_cast<long>(i));
    }
  } else {
    describe_clouds(*rec, std::move(scans), points->name, options.lidar_model, ds);
  }

  // Odometry: the LiDAR's poses in the odometry frame, through the base frame's extrinsics.
  if (!odo.empty()) {
    info.base_frame = ros::frame_name(odo.front().child_frame_id);
    std::optional<Pose> base_lidar = tree.between(info.base_frame, info.lidar_frame);
    if (!base_lidar) {
      info.notes.push_back("no /tf_static path from " + info.base_frame + " to " + info.lidar_frame + ": odometry taken as the LiDAR's own");
      base_lidar = Pose::Identity();
    }
    for (const ros::Odometry& o : odo) ds.odometry.push_back({ns_to_seconds(o.header.stamp_ns), Pose(o.pose * *base_lidar)});
    std::stable_sort(ds.odometry.begin(), ds.odometry.end(), [](const OdometrySample& a, const OdometrySample& b) { return a.t < b.t; });
  }

  // Ground truth: the reference's poses turned into the LiDAR's, interpolated at each scan's stamp.
  if (truth) {
    if (gt.empty()) throw Error(path + ": the truth topic " + truth->name + " has no messages");
    std::stable_sort(gt.begin(), gt.end(), [](const ros::Odometry& a, const ros::Odometry& b) { return a.header.stamp_ns < b.header.stamp_ns; });
    const std::string child = ros::frame_name(gt.front().child_frame_id);
    std::optional<Pose> child_lidar = tree.between(child, info.lidar_frame);
    if (!child_lidar) {
      info.notes.push_back("no /tf_static path from " + child + " to " + info.lidar_frame + ": the truth taken as the LiDAR's own poses");
      child_lidar = Pose::Identity();
    }
    ds.ground_truth.format = PoseFormat::Kitti;
    for (double t : ds.times) {
      const std::int64_t ns = static_cast<std::int64_t>(std::llround(t * 1e9));
      auto hi = std::lower_bound(gt.begin(), gt.end(), ns, [](const ros::Odometry& o, std::int64_t v) { return o.header.stamp_ns < v; });
      Pose p;
      // Within a microsecond of a pose's stamp: that pose (a scan time in double seconds is good to
      // about 0.2 us, so the stamp it came from may lie on either side).
      if (hi != gt.end() && hi->header.stamp_ns - ns <= 1000) {
        p = hi->pose;
      } else if (hi != gt.begin() && ns - (hi - 1)->header.stamp_ns <= 1000) {
        p = (hi - 1)->pose;
      } else if (hi == gt.begin() || hi == gt.end()) {
        throw Error(path + ": the truth topic " + truth->name + " does not cover the scan at " + std::to_string(t) + " s (it spans " +
                    std::to_string(ns_to_seconds(gt.front().header.stamp_ns)) + " to " + std::to_string(ns_to_seconds(gt.back().header.stamp_ns)) + " s)");
      } else {
        const auto lo = hi - 1;
        const double s = static_cast<double>(ns - lo->header.stamp_ns) / static_cast<double>(hi->header.stamp_ns - lo->header.stamp_ns);
        p = interpolate(lo->pose, hi->pose, s);
      }
      ds.ground_truth.poses.push_back(p * *child_lidar);
    }
    ds.ground_truth.times = ds.times;
  }

  // GPS: a fix's status and covariance as the GPS model's status and standard deviation. Drivers
  // report RTK as GBAS_FIX (2); its standard deviation tells a fixed solution from a float one.
  for (const ros::NavSatFix& f : fixes) {
    if (!(std::abs(f.latitude) < 90) || !(std::abs(f.longitude) <= 180) || !std::isfinite(f.altitude)) continue;
    GpsFix g;
    g.t = ns_to_seconds(f.header.stamp_ns);
    g.position = {f.latitude, f.longitude, f.altitude};
    const double var = 0.5 * (f.covariance[0] + f.covariance[4]);
    g.std_m = f.covariance_type > 0 && var > 0 && std::isfinite(var) ? std::sqrt(var) : f.status >= 2 ? 0.05 : f.status == 1 ? 1.0 : 3.0;
    g.status = f.status < 0 ? kGpsNone : f.status == 0 ? kGpsSingle : f.status == 1 ? kGpsDgps : g.std_m <= 0.05 ? kGpsFixed : kGpsFloat;
    ds.gps.push_back(g);
  }
  if (!ds.gps.empty()) {
    info.gps_frame = ros::frame_name(fixes.front().header.frame_id);
    if (std::optional<Pose> lidar_gps = tree.between(info.lidar_frame, info.gps_frame))
      ds.meta.vehicle.gps_lever_arm = lidar_gps->translation();
    else
      info.notes.push_back("no /tf_static path from " + info.lidar_frame + " to the GPS antenna's frame " + info.gps_frame +
                           ": the lever arm is taken as zero");
    auto usable = std::find_if(ds.gps.begin(), ds.gps.end(), [](const GpsFix& g) { return g.status != kGpsNone; });
    if (usable != ds.gps.end()) {
      ds.projection.kind = WorldProjection::Kind::Enu;
      ds.projection.origin = usable->position;
      ds.meta.origin = usable->position;
    }
  }

  // What each topic is and what was taken from it.
  for (std::uint32_t k = 0; k < r.topics().size(); ++k) {
    const bag::Topic& t = r.topics()[k];
    RecordingInfo::TopicUse u;
    u.name = t.name;
    u.type = t.type;
    u.encoding = encoding_name(t.encoding);
    u.count = t.count;
    const auto& ts = topic_times[k];
    if (!ts.empty()) {
      u.first_s = ts.front();
      u.last_s = ts.back();
      if (ts.size() > 1 && u.last_s > u.first_s) u.rate_hz = (ts.size() - 1) / (u.last_s - u.first_s);
      for (std::size_t j = 1; j < ts.size(); ++j) u.max_gap_s = std::max(u.max_gap_s, ts[j] - ts[j - 1]);
    }
    u.frame_id = topic_frames[k];
    if (k == pi) u.use = "scans";
    else if (truth && k == ti) u.use = "truth";
    else if (odom && k == oi) u.use = "odometry";
    else if (gps && k == gi) u.use = "gps";
    else if (t.type == "tf2_msgs/TFMessage" && (t.name == "/tf_static" || t.name == "tf_static")) u.use = "extrinsics";
    info.topics.push_back(u);
  }
  ds.recording = std::move(rec);
  // As open_dataset: the truth's rotations on their grid, the same bits as the folder the recording came from.
  for (Pose& p : ds.ground_truth.poses) p = canonical_rotation(p);
  return ds;
}

}  // namespace pl

#include "localizer_node.hpp"

#include <diagnostic_msgs/DiagnosticArray.h>
#include <geometry_msgs/PoseWithCovarianceStamped.h>
#include <geometry_msgs/TransformStamped.h>
#include <nav_msgs/Odometry.h>
#include <sensor_msgs/NavSatFix.h>
#include <sensor_msgs/PointCloud2.h>
#include <tf2_ros/transform_broadcaster.h>
#include <tf2_ros/transform_listener.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <deque>
#include <iterator>
#include <mutex>
#include <optional>
#include <thread>

#include "convert.hpp"
#include "params.hpp"
#include "pl/client/config_fields.hpp"
#include "pl/client/vehicle_localizer.hpp"
#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"
#include "pl/recordings/dataset.hpp"

namespace pl::ros1 {
namespace {

namespace msg = pl::ros;

using client::Health;
using client::PoseEstimate;
using client::ScanReport;
using client::VehicleLocalizer;
using client::VehicleLocalizerConfig;

struct HeldScan {
  double t = 0, covered_at = 0;  // the stamp; the odometry time that covers its sweep
  ::ros::WallTime arrived;
  Scan points;
  std::vector<std::uint16_t> rings;
  std::vector<float> times;
};

}  // namespace

struct LocalizerNode::Impl {
  ::ros::NodeHandle nh, pnh;
  // Parameters.
  VehicleLocalizerConfig cfg;
  std::string map_frame = "map", odom_frame, base_frame, init = "wait", deskew = "auto";
  bool publish_tf = true, queue_scans = false, initial_search = true, use_odometry = true;
  int beams = 0;
  double odometry_wait_s = 0.2, retry_s = 2.0;
  std::optional<Eigen::Isometry3d> initial_pose, base_from_lidar_param;
  std::optional<Eigen::Vector3d> base_from_antenna_param;
  std::optional<GeoPoint> map_origin;

  // ROS.
  tf2_ros::Buffer tf_buffer;
  tf2_ros::TransformListener tf_listener{tf_buffer};
  tf2_ros::TransformBroadcaster tf_out;
  ::ros::Subscriber points_sub, odom_sub, fix_sub, initial_sub;
  ::ros::Publisher odom_pub, pose_pub, diag_pub;
  ::ros::WallTimer release_timer, diag_timer;

  // State, under m.
  std::mutex m;
  std::condition_variable cv;
  bool stop = false, abandon = false;  // abandon: the connector's, on a restart
  std::shared_ptr<VehicleLocalizer> loc;
  struct SensorInfo {
    std::string frame;
    int beams = 0;  // the highest ring + 1
    bool times = false;
  };
  std::optional<SensorInfo> first_cloud;
  bool sensor_known = false;  // the extrinsics, beams and point times are known: the localizer can be made
  static constexpr std::size_t kMaxHeld = 50;
  std::string connect_error;
  int connect_attempts = 0;
  std::deque<std::pair<double, Eigen::Isometry3d>> early_odometry;  // before the localizer exists
  std::deque<HeldScan> held;                                        // waiting for the odometry
  std::deque<HeldScan> queue;                                       // ~queue_scans: waiting for the worker
  double last_odom_t = -1e300, last_scan_t = -1e300;
  static constexpr double kJumpBack = 1.0;  // seconds back in time that restart the node
  Eigen::Isometry3d last_odom = Eigen::Isometry3d::Identity();
  ::ros::WallTime last_odom_wall;
  std::optional<std::pair<Eigen::Isometry3d, bool>> pending_start;  // base pose, search round it
  bool started = false, global_pending = false;
  std::size_t scans = 0, dropped = 0, ok = 0, degraded = 0, lost = 0;
  std::optional<ScanReport> last_report;
  std::string last_problem;
  std::thread connector, feeder;

  Impl(::ros::NodeHandle n, ::ros::NodeHandle p) : nh(std::move(n)), pnh(std::move(p)) {
    read_params();
    const std::uint32_t q = 10;
    odom_pub = pnh.advertise<nav_msgs::Odometry>("odometry", 50);
    pose_pub = pnh.advertise<geometry_msgs::PoseWithCovarianceStamped>("pose", q);
    diag_pub = nh.advertise<diagnostic_msgs::DiagnosticArray>("/diagnostics", q);
    points_sub = nh.subscribe("points", 5, &Impl::on_points, this, ::ros::TransportHints().tcpNoDelay());
    if (use_odometry) odom_sub = nh.subscribe("odom", 200, &Impl::on_odometry, this, ::ros::TransportHints().tcpNoDelay());
    fix_sub = nh.subscribe("fix", 20, &Impl::on_fix, this);
    initial_sub = nh.subscribe("/initialpose", 2, &Impl::on_initial_pose, this);
    release_timer = nh.createWallTimer(::ros::WallDuration(0.02), [this](const ::ros::WallTimerEvent&) { release(); });
    diag_timer = nh.createWallTimer(::ros::WallDuration(1.0), [this](const ::ros::WallTimerEvent&) { publish_diagnostics(); });
    connector = std::thread([this] { connect_loop(); });
    if (queue_scans) feeder = std::thread([this] { feed_loop(); });
  }

  ~Impl() {
    {
      std::lock_guard<std::mutex> lk(m);
      stop = true;
    }
    cv.notify_all();
    if (connector.joinable()) connector.join();
    if (feeder.joinable()) feeder.join();
    std::shared_ptr<VehicleLocalizer> l;
    {
      std::lock_guard<std::mutex> lk(m);
      l.swap(loc);
    }
    l.reset();  // joins the worker, whose callback publishes: before the publishers go
  }

  void read_params() {
    std::string server, store;
    pnh.param<std::string>("server", server, "");
    pnh.param<std::string>("store", store, "");
    if (server.empty() == store.empty())
      throw Error("set exactly one of ~server (pl-server's URL, http://HOST:PORT) or ~store (a local map store file)");
    cfg.tiles.server = server;
    cfg.store_path = store;
    if (!pnh.getParam("map", cfg.tiles.map) || cfg.tiles.map.empty()) throw Error("set ~map: the map's name (pl-map list)");
    int version = 0;
    pnh.param("map_version", version, 0);
    if (version < 0) throw Error("~map_version must be 0 (the current one) or a version number");
    if (version > 0) cfg.tiles.version = version;
    pnh.param<std::string>("cache", cfg.tiles.cache_path, "");
    pnh.param<std::string>("token", cfg.tiles.token, "");
    pnh.param<std::string>("map_frame", map_frame, "map");
    pnh.param<std::string>("odom_frame", odom_frame, "");
    pnh.param<std::string>("base_frame", base_frame, "");
    pnh.param("publish_tf", publish_tf, true);
    pnh.param("use_odometry", use_odometry, true);
    pnh.param("queue_scans", queue_scans, false);
    pnh.param("odometry_wait_s", odometry_wait_s, 0.2);
    pnh.param("retry_s", retry_s, 2.0);
    pnh.param("beams", beams, 0);
    pnh.param<std::string>("deskew", deskew, "auto");
    pnh.param<std::string>("init", init, "");
    pnh.param("initial_search", initial_search, true);
    if (!(odometry_wait_s >= 0) || !(retry_s > 0)) throw Error("~odometry_wait_s must be >= 0 and ~retry_s > 0");
    if (beams < 0) throw Error("~beams must be 0 (all) or the beams kept");
    if (deskew != "auto" && deskew != "on" && deskew != "off") throw Error("~deskew must be auto, on or off, not " + deskew);
    if (const auto v = param_list(pnh, "initial_pose"); !v.empty()) initial_pose = pose_from_list(v, pnh.resolveName("initial_pose"));
    if (init.empty()) init = initial_pose ? "pose" : "wait";
    if (init != "pose" && init != "gps" && init != "global" && init != "wait")
      throw Error("~init must be pose (~initial_pose), gps, global or wait (for /initialpose), not " + init);
    if (init == "pose" && !initial_pose) throw Error("~init pose needs ~initial_pose: [x, y, z, roll, pitch, yaw] (m, deg)");
    if (const auto v = param_list(pnh, "base_from_lidar"); !v.empty()) base_from_lidar_param = pose_from_list(v, pnh.resolveName("base_from_lidar"));
    if (const auto v = param_list(pnh, "base_from_antenna"); !v.empty()) {
      if (v.size() != 3) throw Error(pnh.resolveName("base_from_antenna") + ": expected [x, y, z] (metres)");
      base_from_antenna_param = Eigen::Vector3d(v[0], v[1], v[2]);
    }
    if (const auto v = param_list(pnh, "map_origin"); !v.empty()) {
      if (v.size() != 3 || std::abs(v[0]) > 90 || std::abs(v[1]) > 180)
        throw Error(pnh.resolveName("map_origin") + ": expected [latitude, longitude, altitude] (degrees, metres)");
      map_origin = GeoPoint{v[0], v[1], v[2]};
    }
    cfg.start_from_gps = init == "gps";
    // Every setting of the localizer by its name (pl-localize --list-settings), e.g. ~localizer/icp/kernel_m.
    int from_params = 0;
    for (const client::ConfigField& f : client::config_fields(cfg)) {
      // The node's own parameters set these (the map source, ~beams, ~deskew, ~init).
      static const char* const own[] = {"tiles/server", "tiles/map", "store_path", "tiles/token", "tiles/cache_path",
                                         "localizer/scan/beams", "localizer/scan/sensor_beams", "localizer/compensate_motion",
                                         "start_from_gps"};
      if (std::find(std::begin(own), std::end(own), f.name) != std::end(own)) {
        if (pnh.hasParam(f.name))
          throw Error("parameter " + pnh.resolveName(f.name) + " is set by the node itself: use ~server/~store, ~map, ~token, "
                      "~cache, ~beams, ~deskew or ~init");
        continue;
      }
      if (const auto text = param_text(pnh, f.name)) {
        client::set_config_field(cfg, f.name, *text);
        ++from_params;
      }
    }
    // Out of range is a mistake in the parameters, not a map to wait for: refused at start, naming it.
    client::check_localizer_config(cfg.localizer);
    ROS_INFO("pl_localizer: map %s from %s; %d localizer settings from parameters; start: %s", cfg.tiles.map.c_str(),
             server.empty() ? store.c_str() : server.c_str(), from_params, init.c_str());
    if (initial_pose) pending_start = std::make_pair(*initial_pose, initial_search);
    if (init == "global") global_pending = true;
  }

  // --- Inputs (the spinner's thread). ---

  void on_points(const sensor_msgs::PointCloud2ConstPtr& msg) {
    try {
      const auto bytes = serialize(*msg);
      msg::PointCloud cloud = pl::ros::decode_point_cloud2(view(bytes), bag::Encoding::Ros1, nh.resolveName("points"));
      const double t = ns_to_seconds(cloud.header.stamp_ns);
      if (t < last_scan_t - kJumpBack) restart("the scans' clock jumped back");
      std::unique_lock<std::mutex> lk(m);
      last_scan_t = t;
      ++scans;
      if (!first_cloud) {
        SensorInfo info;
        info.frame = msg::frame_name(cloud.header.frame_id);
        for (std::uint16_t r : cloud.rings) info.beams = std::max(info.beams, r + 1);
        info.times = !cloud.times.empty();
        first_cloud = info;
      }
      if (!sensor_known) learn_sensor();
      HeldScan h;
      h.t = t;
      float latest = 0;
      for (float x : cloud.times) latest = std::max(latest, x);
      h.covered_at = t + latest;
      h.arrived = ::ros::WallTime::now();
      h.points = std::move(cloud.points);
      h.rings = std::move(cloud.rings);
      h.times = std::move(cloud.times);
      held.push_back(std::move(h));
      // Until the localizer exists (the map service answers) the newest scans wait; older ones go.
      while (held.size() > kMaxHeld) {
        held.pop_front();
        ++dropped;
      }
      release_locked();
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5.0, "pl_localizer: scan dropped: %s", e.what());
    }
  }

  // From the first scan: the LiDAR's frame (extrinsics), beams and point times. Then the localizer
  // can be made (the connector waits for this). Returns false while the extrinsics are not known
  // yet (tried again on every scan and odometry message). Under m.
  bool learn_sensor() {
    if (sensor_known) return true;
    if (!first_cloud) return false;
    const std::string& lidar_frame = first_cloud->frame;
    if (base_frame.empty() && use_odometry && last_odom_t == -1e300) {
      ROS_WARN_THROTTLE(5.0, "pl_localizer: waiting for the first odometry message (it names the base frame; or set ~base_frame)");
      return false;
    }
    const std::string base = base_frame.empty() ? "base_link" : base_frame;
    if (base_from_lidar_param) {
      cfg.base_from_lidar = *base_from_lidar_param;
    } else {
      try {
        cfg.base_from_lidar = from_msg(tf_buffer.lookupTransform(base, lidar_frame, ::ros::Time(0)).transform);
      } catch (const tf2::TransformException& e) {
        ROS_WARN_THROTTLE(5.0, "pl_localizer: no transform %s <- %s yet (%s): publish it on /tf_static or set ~base_from_lidar",
                          base.c_str(), lidar_frame.c_str(), e.what());
        return false;
      }
    }
    const int sensor_beams = std::max(1, first_cloud->beams);
    if (beams > sensor_beams || (beams > 0 && sensor_beams % beams != 0))
      throw Error("~beams " + std::to_string(beams) + " must divide the sensor's " + std::to_string(sensor_beams) + " beams");
    cfg.localizer.scan.sensor_beams = sensor_beams;
    cfg.localizer.scan.beams = beams > 0 ? beams : sensor_beams;
    cfg.localizer.compensate_motion = deskew == "on" || (deskew == "auto" && first_cloud->times);
    if (base_from_antenna_param) cfg.base_from_antenna = *base_from_antenna_param;
    sensor_known = true;
    ROS_INFO("pl_localizer: LiDAR frame %s, %d beams (%d kept), point times %s, deskew %s", lidar_frame.c_str(), sensor_beams,
             cfg.localizer.scan.beams, first_cloud->times ? "yes" : "no", cfg.localizer.compensate_motion ? "on" : "off");
    cv.notify_all();
    return true;
  }

  void on_odometry(const nav_msgs::OdometryConstPtr& msg) {
    try {
      const auto bytes = serialize(*msg);
      const msg::Odometry o = pl::ros::decode_odometry(view(bytes), bag::Encoding::Ros1, nh.resolveName("odom"));
      const double t = ns_to_seconds(o.header.stamp_ns);
      std::shared_ptr<VehicleLocalizer> l;
      Frames frames;
      if (t < last_odom_t - kJumpBack) restart("the odometry's clock jumped back");
      {
        std::lock_guard<std::mutex> lk(m);
        if (t <= last_odom_t) return;  // a repeat or out of order: the odometry's times must increase
        if (base_frame.empty()) base_frame = msg::frame_name(o.child_frame_id);
        if (odom_frame.empty()) odom_frame = msg::frame_name(o.header.frame_id);
        last_odom_t = t;
        last_odom = o.pose;
        last_odom_wall = ::ros::WallTime::now();
        if (!sensor_known) learn_sensor();
        l = loc;
        if (!l) {
          early_odometry.emplace_back(t, o.pose);
          while (early_odometry.size() > cfg.max_odometry_samples) early_odometry.pop_front();
          return;
        }
        // Under the lock: the connector hands the early odometry over under it too (times stay in order).
        l->add_odometry_pose(t, o.pose);
        release_locked();
        frames = frames_locked();
      }
      publish_fused(*l, t, &o.pose, msg->header.stamp, frames);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5.0, "pl_localizer: odometry dropped: %s", e.what());
    }
  }

  // A fix in the map frame: about ~map_origin, else the map's own origin (from the map service).
  void on_fix(const sensor_msgs::NavSatFixConstPtr& msg) {
    try {
      const auto bytes = serialize(*msg);
      const msg::NavSatFix f = pl::ros::decode_nav_sat_fix(view(bytes), bag::Encoding::Ros1, nh.resolveName("fix"));
      if (f.status < 0 || !(std::abs(f.latitude) < 90) || !(std::abs(f.longitude) <= 180)) return;
      std::lock_guard<std::mutex> lk(m);
      if (!loc) return;
      const Eigen::Vector3d enu = EnuFrame(map_origin ? *map_origin : loc->map_origin()).to_enu({f.latitude, f.longitude, f.altitude});
      loc->add_gps(ns_to_seconds(f.header.stamp_ns), enu);
    } catch (const std::exception& e) {
      ROS_ERROR_THROTTLE(5.0, "pl_localizer: fix dropped: %s", e.what());
    }
  }

  void on_initial_pose(const geometry_msgs::PoseWithCovarianceStampedConstPtr& msg) {
    if (!msg->header.frame_id.empty() && msg::frame_name(msg->header.frame_id) != map_frame) {
      ROS_WARN("pl_localizer: /initialpose in frame %s ignored: give it in %s", msg->header.frame_id.c_str(), map_frame.c_str());
      return;
    }
    std::lock_guard<std::mutex> lk(m);
    pending_start = std::make_pair(from_msg(msg->pose.pose), true);  // rviz's estimate is rough: searched round
    ROS_INFO("pl_localizer: /initialpose at (%.2f, %.2f): the next scan searches round it", msg->pose.pose.position.x,
             msg->pose.pose.position.y);
  }

  // --- Scans to the localizer. ---

  // Hands over the held scans the odometry now covers (or that waited long enough). Under m.
  void release_locked() {
    if (!loc) return;
    const ::ros::WallTime now = ::ros::WallTime::now();
    const bool odometry_live = use_odometry && last_odom_t > -1e300 && (now - last_odom_wall).toSec() < 1.0;
    while (!held.empty()) {
      HeldScan& h = held.front();
      const bool covered = !odometry_live || last_odom_t >= h.covered_at;
      if (!covered && (now - h.arrived).toSec() < odometry_wait_s) break;
      HeldScan s = std::move(h);
      held.pop_front();
      if (queue_scans) {
        queue.push_back(std::move(s));
        cv.notify_all();
      } else {
        hand_over(s);
      }
    }
  }

  void release() {
    std::lock_guard<std::mutex> lk(m);
    release_locked();
  }

  // A start asked for (parameters, /initialpose, global), then the scan. Under m.
  void hand_over(HeldScan& s) {
    if (pending_start) {
      const auto [pose, search] = *pending_start;
      pending_start.reset();
      search ? loc->start_near(pose, s.t) : loc->start(pose, s.t);
      started = true;
    } else if (global_pending) {
      global_pending = false;
      loc->start_global(s.t);
      started = true;
    }
    if (!started && !cfg.start_from_gps) {
      ++dropped;
      ROS_WARN_THROTTLE(10.0, "pl_localizer: not started: give a pose on /initialpose (rviz: 2D Pose Estimate) or set ~init");
      return;
    }
    started = true;
    if (cfg.localizer.scan.beams >= cfg.localizer.scan.sensor_beams) s.rings.clear();  // all beams kept: not needed
    loc->add_scan(s.t, s.points, s.rings, s.times);
  }

  // ~queue_scans: one scan at a time, each waited for.
  void feed_loop() {
    std::unique_lock<std::mutex> lk(m);
    while (true) {
      cv.wait(lk, [&] { return stop || !queue.empty(); });
      if (stop) return;
      HeldScan s = std::move(queue.front());
      queue.pop_front();
      std::shared_ptr<VehicleLocalizer> l = loc;
      hand_over(s);
      lk.unlock();
      l->wait_idle(600.0);
      lk.lock();
    }
  }

  // A clock that jumps back (a recording played again, a simulator reset): everything since is
  // forgotten and the node starts again as launched (the localizer is made anew). Spinner thread.
  void restart(const char* why) {
    std::shared_ptr<VehicleLocalizer> old;
    std::thread old_connector;
    {
      std::lock_guard<std::mutex> lk(m);
      ROS_WARN("pl_localizer: %s: starting again", why);
      old.swap(loc);
      abandon = true;  // the connector, if still trying, gives up
      held.clear();
      queue.clear();
      early_odometry.clear();
      last_odom_t = last_scan_t = -1e300;
      started = false;
      last_report.reset();
      pending_start.reset();
      if (initial_pose) pending_start = std::make_pair(*initial_pose, initial_search);
      global_pending = init == "global";
      old_connector.swap(connector);
    }
    cv.notify_all();
    if (old_connector.joinable()) old_connector.join();
    old.reset();  // unless the feeder still waits on it
    {
      std::lock_guard<std::mutex> lk(m);
      abandon = false;
      connector = std::thread([this] { connect_loop(); });
    }
  }

  // --- The localizer, made once the sensor is known and the map source answers. ---

  void connect_loop() {
    std::unique_lock<std::mutex> lk(m);
    cv.wait(lk, [&] { return stop || abandon || sensor_known; });
    while (!stop && !abandon) {
      const VehicleLocalizerConfig c = cfg;
      ++connect_attempts;
      lk.unlock();
      std::shared_ptr<VehicleLocalizer> l;
      std::string problem;
      try {
        l = std::make_shared<VehicleLocalizer>(c);
        l->on_scan([this](const ScanReport& r) { on_report(r); });
      } catch (const std::exception& e) {
        problem = e.what();
      }
      lk.lock();
      if (l && abandon) return;
      if (l) {
        for (const auto& [t, pose] : early_odometry) l->add_odometry_pose(t, pose);
        early_odometry.clear();
        loc = l;
        connect_error.clear();
        release_locked();
        ROS_INFO("pl_localizer: map %s version %lld ready (tile size %.0f m)", c.tiles.map.c_str(), l->map_version(), l->tile_size());
        return;
      }
      connect_error = problem;
      ROS_ERROR("pl_localizer: cannot open the map yet (attempt %d; retrying every %.1f s): %s", connect_attempts, retry_s, problem.c_str());
      cv.wait_for(lk, std::chrono::duration<double>(retry_s), [&] { return stop || abandon; });
    }
  }

  // --- Outputs. ---

  // On the localizer's worker after each scan.
  void on_report(const ScanReport& r) {
    std::shared_ptr<VehicleLocalizer> l;
    Frames frames;
    bool odometry = false;
    {
      std::lock_guard<std::mutex> lk(m);
      last_report = r;
      (r.health == Health::Ok ? ok : r.health == Health::Degraded ? degraded : lost)++;
      l = loc;
      frames = frames_locked();
      odometry = use_odometry && last_odom_t > -1e300;
    }
    const Eigen::Isometry3d base = r.fused * cfg.base_from_lidar.inverse();
    geometry_msgs::PoseWithCovarianceStamped p;
    p.header.stamp = ros_time(r.t);
    p.header.frame_id = map_frame;
    p.pose.pose = to_msg(base);
    const PoseEstimate e = l ? l->pose_at(r.t) : PoseEstimate{};
    p.pose.covariance = covariance_in_map(e.covariance, base);
    pose_pub.publish(p);
    if (!odometry && l) publish_fused(*l, r.t, nullptr, ros_time(r.t), frames);
  }

  // The fused pose at t on ~odometry, and map -> odom (map -> base without odometry).
  struct Frames {
    std::string base, odom;
  };
  Frames frames_locked() const { return {base_frame.empty() ? "base_link" : base_frame, odom_frame.empty() ? "odom" : odom_frame}; }

  void publish_fused(VehicleLocalizer& l, double t, const Eigen::Isometry3d* base_in_odom, const ::ros::Time& stamp, const Frames& frames) {
    const PoseEstimate e = l.pose_at(t);
    if (!e.valid) return;
    const std::string& base = frames.base;
    nav_msgs::Odometry o;
    o.header.stamp = stamp;
    o.header.frame_id = map_frame;
    o.child_frame_id = base;
    o.pose.pose = to_msg(e.base_in_map);
    o.pose.covariance = covariance_in_map(e.covariance, e.base_in_map);
    odom_pub.publish(o);
    if (!publish_tf) return;
    geometry_msgs::TransformStamped tf;
    tf.header.stamp = stamp;
    tf.header.frame_id = map_frame;
    if (base_in_odom) {
      tf.child_frame_id = frames.odom;
      tf.transform = to_transform_msg(e.base_in_map * base_in_odom->inverse());
    } else {
      tf.child_frame_id = base;
      tf.transform = to_transform_msg(e.base_in_map);
    }
    tf_out.sendTransform(tf);
  }

  void publish_diagnostics() {
    diagnostic_msgs::DiagnosticArray a;
    a.header.stamp = ::ros::Time::now();
    diagnostic_msgs::DiagnosticStatus s, c;
    s.name = "pl_localizer: localization";
    s.hardware_id = cfg.tiles.map;
    c.name = "pl_localizer: map tiles";
    c.hardware_id = cfg.tiles.server.empty() ? cfg.store_path : cfg.tiles.server;
    std::shared_ptr<VehicleLocalizer> l;
    {
      std::lock_guard<std::mutex> lk(m);
      l = loc;
      s.values = {kv("scans", std::to_string(scans)), kv("dropped", std::to_string(dropped)), kv("ok", std::to_string(ok)),
                  kv("degraded", std::to_string(degraded)), kv("lost", std::to_string(lost)),
                  kv("waiting_for_odometry", std::to_string(held.size())), kv("queued", std::to_string(queue.size()))};
      if (!l) {
        s.level = diagnostic_msgs::DiagnosticStatus::ERROR;
        s.message = sensor_known ? "no map yet: " + connect_error : "waiting for the first scan";
        c.level = diagnostic_msgs::DiagnosticStatus::ERROR;
        c.message = sensor_known ? connect_error : "not connected yet";
        c.values = {kv("attempts", std::to_string(connect_attempts))};
      } else if (!last_report) {
        s.level = diagnostic_msgs::DiagnosticStatus::WARN;
        s.message = started || pending_start || global_pending || cfg.start_from_gps ? "starting" : "waiting for /initialpose";
      } else {
        const ScanReport& r = *last_report;
        s.level = r.health == Health::Ok ? diagnostic_msgs::DiagnosticStatus::OK
                  : r.health == Health::Degraded ? diagnostic_msgs::DiagnosticStatus::WARN
                                                 : diagnostic_msgs::DiagnosticStatus::ERROR;
        s.message = std::string(client::health_name(r.health)) + (r.note.empty() ? "" : ": " + r.note);
        s.values.push_back(kv("health", client::health_name(r.health)));
        s.values.push_back(kv("protection_m", num(r.protection_m)));
        s.values.push_back(kv("registration_sigma_m", num(r.registration_sigma_m)));
        s.values.push_back(kv("last_scan_t", num(r.t, "%.6f")));
        s.values.push_back(kv("registration_ms", num(r.register_ms, "%.2f")));
        s.values.push_back(kv("map_outdated", r.map_outdated ? "true" : "false"));
        s.values.push_back(kv("motion", r.motion));
      }
    }
    if (l) {
      const client::TileClientStatus st = l->tile_status();
      const bool local = !cfg.store_path.empty();
      // Online with a problem standing (an answer refused: a manifest or tile altered on the way, a
      // current-version statement held back) is a warning too.
      c.level = local || (st.online && st.last_error.empty()) ? diagnostic_msgs::DiagnosticStatus::OK : diagnostic_msgs::DiagnosticStatus::WARN;
      c.message = local ? "local store" : !st.online ? "offline: " + st.last_error : st.last_error.empty() ? "online" : "online; " + st.last_error;
      c.values = {kv("online", local || st.online ? "true" : "false"), kv("version", std::to_string(l->map_version())),
                  kv("tiles_in_memory", std::to_string(st.tiles_in_memory)), kv("fetched", std::to_string(st.fetched)),
                  kv("from_disk", std::to_string(st.from_disk)), kv("failures", std::to_string(st.failures)),
                  kv("retries", std::to_string(st.retries)), kv("rejected", std::to_string(st.rejected)),
                  kv("confirmed_version", std::to_string(st.confirmed_version)), kv("confirmed_until", std::to_string(st.confirmed_until)),
                  kv("last_error", st.last_error)};
      if (const std::string e = l->last_error(); !e.empty()) s.values.push_back(kv("error", e));
    }
    a.status = {s, c};
    diag_pub.publish(a);
  }
};

LocalizerNode::LocalizerNode(::ros::NodeHandle nh, ::ros::NodeHandle private_nh)
    : impl_(std::make_unique<Impl>(std::move(nh), std::move(private_nh))) {}

LocalizerNode::~LocalizerNode() = default;

}  // namespace pl::ros1

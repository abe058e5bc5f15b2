// The worker thread owns the ROI map and the registration; one mutex guards what the input and
// output threads share with it: the odometry buffer, the filter (inside the Localizer), the start
// request, the waiting scan and the last report. Registration itself runs without the lock, so
// pose_at() never waits for ICP.
#include "pl/client/vehicle_localizer.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <deque>
#include <mutex>
#include <optional>
#include <sstream>
#include <thread>

#include "pl/client/config_fields.hpp"
#include "pl/client/store_tiles.hpp"
#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"

namespace pl::client {
namespace {

double now_ms() { return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now().time_since_epoch()).count(); }

struct ScanJob {
  double t = 0;
  Scan points;
  std::vector<std::uint16_t> rings;
  std::vector<float> times;
  std::vector<Eigen::Vector3f> origins;  // after deskew: where the sensor was at each point's firing (scan frame)
};

enum class StartRequest { None, At, Near, Global };

// Waits up to cfg.ready_timeout_s for the map's version and tile size, telling cfg.on_wait what it
// waits for after 1 s and then at doubling intervals. Returns whether the map is ready.
bool wait_for_map(TileClient& client, const VehicleLocalizerConfig& cfg) {
  const auto t0 = std::chrono::steady_clock::now();
  double next = 1.0;
  for (;;) {
    const double waited = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (waited >= cfg.ready_timeout_s) return client.wait_ready(0.0);
    if (client.wait_ready(std::min(next, cfg.ready_timeout_s) - waited)) return true;
    if (cfg.on_wait && next < cfg.ready_timeout_s) {
      const std::string why = client.status().last_error;
      std::ostringstream line;
      line << "waiting for map '" << cfg.tiles.map << "' from " << cfg.tiles.server << " (" << static_cast<int>(next) << " s of "
           << cfg.ready_timeout_s << "): " << (why.empty() ? "no answer yet" : why);
      cfg.on_wait(line.str());
    }
    next *= 2;
  }
}

}  // namespace

struct VehicleLocalizer::Impl {
  VehicleLocalizerConfig cfg;
  std::unique_ptr<TileClient> client;
  std::unique_ptr<StoreTiles> store;
  double tile_size = 0;
  std::atomic<long long> version{0};
  // Following the map's versions (cfg.tiles.follow_s): the client of a newer version loading its
  // tiles beside the one in use, the one it replaced (gone at the next scan: by then idle), the
  // version refused (another frame), and the moves made. The worker's own; read under m.
  TileClientConfig client_cfg;
  std::unique_ptr<TileClient> next, retired;
  long long refused_version = 0;
  std::size_t version_moves = 0;
  GeoPoint origin;
  std::unique_ptr<Localizer> loc;
  std::unique_ptr<ChangeEvidence> evidence;  // touched by the worker while busy, read when not
  std::size_t evidence_skipped = 0;

  mutable std::mutex m;
  mutable std::condition_variable cv;
  OdometryBuffer odo;  // LiDAR poses in the odometry frame
  std::optional<DiffDrive> drive;
  bool have_base = false;
  double last_odo_t = 0;
  Eigen::Isometry3d last_base = Eigen::Isometry3d::Identity();
  Eigen::Vector3d twist_v = Eigen::Vector3d::Zero(), twist_w = Eigen::Vector3d::Zero();
  std::deque<std::pair<double, Eigen::Vector3d>> gps;
  std::atomic<bool> started{false};
  StartRequest request = StartRequest::None;
  Eigen::Isometry3d request_pose = Eigen::Isometry3d::Identity();  // LiDAR in map
  double request_t = 0;
  std::optional<ScanJob> pending;
  bool busy = false, stop = false;
  ScanReport last;
  bool have_report = false;
  double last_fused_t = 0;
  Eigen::Matrix<double, 6, 6> last_cov = Eigen::Matrix<double, 6, 6>::Identity();
  std::string error;
  std::function<void(const ScanReport&)> callback;
  Eigen::Vector2d last_xy = Eigen::Vector2d::Zero();
  double last_scan_t = 0;
  std::thread worker;

  std::vector<MapTile> tiles_near(const Eigen::Vector2d& c, double r) {
    return store ? store->near(c, r) : client->tiles_near(c, r);
  }

  // Tiles round a place far from the vehicle (a search by place): the tile client is asked for
  // them and waited for, briefly. On the worker.
  std::vector<MapTile> tiles_far(const Eigen::Vector2d& c, double r) {
    if (client) {
      client->set_focus(c, c);
      client->wait_for(c, r, std::min(cfg.start_wait_s, 5.0));
    }
    return tiles_near(c, r);
  }

  Eigen::Isometry3d to_lidar(const Eigen::Isometry3d& base) const { return base * cfg.base_from_lidar; }
  Eigen::Isometry3d to_base(const Eigen::Isometry3d& lidar) const { return lidar * cfg.base_from_lidar.inverse(); }

  // Under the lock.
  void add_base_pose(double t, const Eigen::Isometry3d& base) {
    odo.add(t, to_lidar(base));  // throws for times that do not increase
    odo.keep_last(cfg.max_odometry_samples);
    last_base = base;
    last_odo_t = t;
    have_base = true;
  }

  // Focus on the start pose and wait (bounded) for its tiles. Without the lock.
  void load_start_tiles(const Eigen::Isometry3d& lidar) {
    const Eigen::Vector2d xy = lidar.translation().head<2>();
    if (!client) return;
    client->set_focus(xy, xy);
    if (!client->wait_for(xy, cfg.localizer.roi_radius_m, cfg.start_wait_s)) {
      std::lock_guard<std::mutex> lk(m);
      error = "not every tile round the start arrived within " + std::to_string(static_cast<int>(cfg.start_wait_s)) + " s (" +
              client->status().last_error + ")";
    }
  }

  // Under the lock; the lock is held while the start registers (pose_at does not wait: not started).
  void started_at(const Eigen::Isometry3d& lidar, double t) {
    last_xy = lidar.translation().head<2>();
    last_scan_t = t;
    last_fused_t = t;
    have_report = false;
    started = true;
  }

  void run() {
    std::unique_lock<std::mutex> lk(m);
    while (true) {
      cv.wait(lk, [&] { return stop || pending || request == StartRequest::At; });
      if (stop) return;
      busy = true;
      try {
        if (request == StartRequest::At) {
          const Eigen::Isometry3d pose = request_pose;
          const double t = request_t;
          request = StartRequest::None;
          lk.unlock();
          load_start_tiles(pose);
          lk.lock();
          loc->start(pose, t, &odo);
          started_at(pose, t);
        }
        if (pending) {
          ScanJob job = std::move(*pending);
          pending.reset();
          if (started || try_start(job, lk)) process(job, lk);
        }
      } catch (const std::exception& e) {
        error = e.what();
      }
      busy = false;
      cv.notify_all();
    }
  }

  // A start with this scan: round a rough pose or the GPS fix (the scans search within the start
  // search's reach), or anywhere on the map by its places. Called with the lock held.
  bool try_start(const ScanJob& job, std::unique_lock<std::mutex>& lk) {
    if (request == StartRequest::Global) {
      request = StartRequest::None;
      loc->start_global(job.t, &odo);
      started_at(loc->pose_at(job.t), job.t);
      return true;
    }
    Eigen::Isometry3d guess;
    registration::PoseSearch search = cfg.search;
    if (request == StartRequest::Near) {
      guess = request_pose;
    } else if (cfg.start_from_gps) {
      const std::pair<double, Eigen::Vector3d>* fix = nullptr;
      for (const auto& g : gps)
        if (std::abs(g.first - job.t) <= 0.5) fix = &g;
      if (!fix) return false;
      Eigen::Isometry3d base = Eigen::Isometry3d::Identity();  // heading unknown: level, facing +x
      base.translation() = fix->second - cfg.base_from_antenna;
      guess = to_lidar(base);
      search = cfg.gps_search;
    } else {
      return false;  // not started, nothing to start from: the scan is dropped
    }
    lk.unlock();
    load_start_tiles(guess);
    lk.lock();
    loc->start_search(guess, job.t, &odo, search.radius_m, search.yaw_range_deg);
    request = StartRequest::None;
    started_at(guess, job.t);
    return true;
  }

  // A newer version of the map moves in at a safe moment, its tiles loaded first: the client of
  // the new version is made beside the one in use, seeded with the tiles the versions share (an
  // update changes few), and focused where the vehicle goes; once the last scan was ok and every
  // tile round the vehicle is in, it replaces the one in use between two scans. The ROI map then
  // takes the changed tiles (by their hashes) and keeps the others; the pose and the filter go on
  // as they were (the versions share the map frame: one with another origin or grid is refused).
  // The change evidence restarts: what was seen against the old version is no report of the new.
  // With the lock held; from the worker, before a scan.
  void follow_versions(std::unique_lock<std::mutex>& lk) {
    if (!client || client_cfg.follow_s <= 0) return;
    if (retired) {
      auto old = std::move(retired);
      lk.unlock();
      old.reset();  // joins its thread, idle since the move
      lk.lock();
    }
    if (!next) {
      const long long latest = client->status().latest;
      if (latest <= version || latest == refused_version) return;
      TileClientConfig tc = client_cfg;
      tc.version = latest;
      tc.follow_s = 0;
      next = std::make_unique<TileClient>(tc);
      next->seed(client->tiles_near(last_xy, tc.radius_m));
      next->set_focus(last_xy, last_xy);
      return;
    }
    const TileClientStatus ns = next->status();
    if (!ns.ready) return;
    if (ns.tile_size != tile_size || ns.origin.lat_deg != origin.lat_deg || ns.origin.lon_deg != origin.lon_deg ||
        ns.origin.alt_m != origin.alt_m) {
      error = "map " + client_cfg.map + " version " + std::to_string(ns.version) + " has another frame or grid than version " +
              std::to_string(version.load()) + " (origin or tile size): it is not taken mid-drive; restart the vehicle's localizer on it";
      refused_version = ns.version;
      retired = std::move(next);
      return;
    }
    if (!have_report || last.health != Health::Ok) return;  // not while the localization is in doubt
    if (!next->wait_for(last_xy, cfg.localizer.roi_radius_m, 0.0)) return;  // its tiles round the vehicle are not all in yet
    retired = std::move(client);
    client = std::move(next);
    version = ns.version;
    ++version_moves;
    if (evidence) evidence = std::make_unique<ChangeEvidence>(cfg.changes, tile_size);
  }

  // One scan: predict, focus the tiles, prepare, register (unlocked), fuse. Called with the lock held.
  void process(ScanJob& job, std::unique_lock<std::mutex>& lk) {
    follow_versions(lk);
    const double t = job.t;
    Prediction predicted = loc->predict(t);
    if (!job.times.empty()) predicted.compensated = deskew(job);
    lk.unlock();
    const Eigen::Vector2d xy = predicted.pose.translation().head<2>();
    const Eigen::Vector2d velocity =
        t > last_scan_t ? Eigen::Vector2d((xy - last_xy) / (t - last_scan_t)) : Eigen::Vector2d::Zero();
    if (client) client->set_focus(xy, xy + cfg.lookahead_s * velocity);
    if (next) next->set_focus(xy, xy + cfg.lookahead_s * velocity);
    const double t0 = now_ms();
    const Scan prepared = prepare_scan(job.points, job.rings, cfg.localizer.scan);
    const double prep = now_ms() - t0;
    ScanReport r = loc->register_at(t, to_points(prepared), predicted);
    r.prepare_ms = prep;
    lk.lock();
    loc->fuse(r);
    last = r;
    have_report = true;
    last_xy = r.fused.translation().head<2>();
    last_scan_t = t;
    if (r.fused_lidar) {
      last_fused_t = t;
      last_cov = r.icp.covariance;
    }
    if (callback) {
      const auto cb = callback;
      lk.unlock();
      cb(r);
      lk.lock();
    }
    const bool wants_evidence = evidence && r.health == Health::Ok && !r.map_outdated && loc->map();
    if (wants_evidence && pending) ++evidence_skipped;
    if (wants_evidence && !pending) {
      lk.unlock();
      // The returns of the beams and field of view the localizer keeps (a 16-beam vehicle sees what
      // a 16-beam sensor sees), not thinned: the evidence has its own grid.
      // Each ray from where the sensor was when it fired (after deskew; a ray from the scan's
      // origin would cross the gaps between parked cars at the wrong place and seem to pass
      // through them): the points carry their index through the selection in `intensity` (exact
      // in a float up to 2^24 points).
      ScanPrepConfig sc = cfg.localizer.scan;
      sc.voxel_m = 0;
      sc.min_range_m = std::max(sc.min_range_m, cfg.changes.min_range_m);
      sc.max_range_m = std::min(sc.max_range_m, cfg.changes.max_range_m);
      Scan indexed = job.points;
      const bool origins = job.origins.size() == indexed.size() && indexed.size() < (std::size_t{1} << 24);
      if (origins)
        for (std::size_t i = 0; i < indexed.size(); ++i) indexed[i].intensity = static_cast<float>(i);
      const Scan kept = prepare_scan(indexed, job.rings, sc);
      std::vector<Eigen::Vector3f> points, from;
      points.reserve(kept.size());
      for (const PointXYZI& p : kept) {
        points.emplace_back(p.x, p.y, p.z);
        if (origins) from.push_back(job.origins[static_cast<std::size_t>(p.intensity)]);
      }
      evidence->add(r.fused, points, loc->map()->points_map(), from);
      lk.lock();
    }
  }

  // Each point moved to where the sensor was at the scan's time, by the odometry between its own
  // time and the scan's (points whose time the odometry does not cover stay as they are).
  // Returns whether the odometry covered the scan's time (else the localizer compensates by azimuth).
  bool deskew(ScanJob& job) const {
    if (job.times.size() != job.points.size()) return false;
    const auto at_scan = odo.at(job.t);
    if (!at_scan) return false;
    const Eigen::Isometry3d inv = at_scan->inverse();
    if (evidence) job.origins.assign(job.points.size(), Eigen::Vector3f::Zero());
    for (std::size_t i = 0; i < job.points.size(); ++i) {
      const auto at_point = odo.at(job.t + job.times[i]);
      if (!at_point) continue;
      PointXYZI& p = job.points[i];
      const Eigen::Isometry3d moved = inv * *at_point;
      if (evidence) job.origins[i] = moved.translation().cast<float>();
      const Eigen::Vector3d q = moved * Eigen::Vector3d(p.x, p.y, p.z);
      p.x = static_cast<float>(q.x());
      p.y = static_cast<float>(q.y());
      p.z = static_cast<float>(q.z());
    }
    return true;
  }
};

VehicleLocalizer::VehicleLocalizer(const VehicleLocalizerConfig& cfg) : impl_(std::make_unique<Impl>()) {
  Impl& m = *impl_;
  m.cfg = cfg;
  if (!cfg.base_from_lidar.matrix().allFinite() || !cfg.base_from_antenna.allFinite())
    throw Error("VehicleLocalizer: the extrinsics (base_from_lidar, base_from_antenna) must be finite");
  if (!(cfg.lookahead_s >= 0) || !(cfg.start_wait_s >= 0) || !(cfg.ready_timeout_s >= 0))
    throw Error("VehicleLocalizer: lookahead_s, start_wait_s and ready_timeout_s must not be negative");
  if (cfg.max_odometry_samples < 2) throw Error("VehicleLocalizer: max_odometry_samples must be at least 2");
  check_localizer_config(cfg.localizer);  // before the map is opened: a setting's mistake is no map's
  if (cfg.changes.enabled) cfg.changes.validate();
  if (!cfg.store_path.empty()) {
    m.store = std::make_unique<StoreTiles>(cfg.store_path, cfg.tiles.map, cfg.tiles.version.value_or(0));
    m.tile_size = m.store->tile_size();
    m.version = m.store->version();
    m.origin = m.store->origin();
  } else {
    TileClientConfig tc = cfg.tiles;
    tc.radius_m = std::max(tc.radius_m, cfg.localizer.roi_radius_m + 20.0);
    m.client_cfg = tc;
    m.client = std::make_unique<TileClient>(tc);
    if (!wait_for_map(*m.client, cfg)) {
      std::ostringstream waited;
      waited << cfg.ready_timeout_s;
      std::string why = m.client->status().last_error;
      for (const char* tail : {" (retrying in ", " (the tiles in memory"})  // giving up: no retry, no tiles
        if (const auto at = why.find(tail); at != std::string::npos) why.erase(at);
      throw Error("no map '" + tc.map + "' from " + tc.server + " within " + waited.str() + " s, and none in the disk cache: " + why);
    }
    const TileClientStatus st = m.client->status();
    m.tile_size = st.tile_size;
    m.version = st.version;
    m.origin = st.origin;
  }
  if (cfg.wheel_base_m > 0) m.drive.emplace(cfg.wheel_base_m);
  if (cfg.changes.enabled) m.evidence = std::make_unique<ChangeEvidence>(cfg.changes, m.tile_size);
  Impl* raw = impl_.get();
  m.loc = std::make_unique<Localizer>(cfg.localizer, m.tile_size,
                                      [raw](const Eigen::Vector2d& c, double r) { return raw->tiles_near(c, r); });
  // The places of the version, for starts and relocalization anywhere on the map (none: searches
  // stay round the prediction).
  const std::optional<std::string> places = m.store ? m.store->places() : m.client->places(cfg.ready_timeout_s);
  if (places) {
    // Damaged places do not stop the vehicle: it localizes without them and says so.
    const std::string source = "places of map " + cfg.tiles.map + " version " + std::to_string(m.version.load());
    try {
      m.loc->set_places(std::make_shared<const registration::PlaceIndex>(registration::PlaceIndex::decode(*places, source)),
                        [raw](const Eigen::Vector2d& c, double r) { return raw->tiles_far(c, r); });
    } catch (const Error& e) {
      m.error = std::string(e.what()) + "; localizing without them (searches stay round the prediction)";
    }
  }
  m.worker = std::thread([raw] { raw->run(); });
}

VehicleLocalizer::~VehicleLocalizer() {
  {
    std::lock_guard<std::mutex> lk(impl_->m);
    impl_->stop = true;
  }
  impl_->cv.notify_all();
  impl_->worker.join();
}

void VehicleLocalizer::start(const Eigen::Isometry3d& base_in_map, double t) {
  if (!base_in_map.matrix().allFinite() || !std::isfinite(t))
    throw Error("VehicleLocalizer::start: the pose and time must be finite");
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->request = StartRequest::At;
  impl_->request_pose = impl_->to_lidar(base_in_map);
  impl_->request_t = t;
  impl_->cv.notify_all();
}

void VehicleLocalizer::start_near(const Eigen::Isometry3d& rough_base_in_map, double t) {
  if (!rough_base_in_map.matrix().allFinite() || !std::isfinite(t))
    throw Error("VehicleLocalizer::start_near: the pose and time must be finite");
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->started = false;
  impl_->request = StartRequest::Near;
  impl_->request_pose = impl_->to_lidar(rough_base_in_map);
  impl_->request_t = t;
}

void VehicleLocalizer::start_global(double t) {
  if (!std::isfinite(t)) throw Error("VehicleLocalizer::start_global: the time must be finite");
  if (!impl_->loc->has_places())
    throw Error("VehicleLocalizer::start_global: map " + impl_->cfg.tiles.map + " version " + std::to_string(impl_->version.load()) +
                " has no places to search by: rebuild it with pl-map build and pl-map tile, or start from a pose");
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->started = false;
  impl_->request = StartRequest::Global;
  impl_->request_t = t;
}

void VehicleLocalizer::add_odometry_pose(double t, const Eigen::Isometry3d& base_in_odom) {
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->add_base_pose(t, base_in_odom);
}

void VehicleLocalizer::add_odometry_increment(double t, const Eigen::Isometry3d& delta) {
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->add_base_pose(t, impl_->last_base * delta);
}

void VehicleLocalizer::add_twist(double t, const Eigen::Vector3d& v, const Eigen::Vector3d& w) {
  if (!v.allFinite() || !w.allFinite()) throw Error("VehicleLocalizer::add_twist: the twist must be finite");
  std::lock_guard<std::mutex> lk(impl_->m);
  Impl& m = *impl_;
  // The previous twist held over the interval since the previous sample.
  Eigen::Isometry3d next = m.last_base;
  if (m.have_base) {
    const double dt = t - m.last_odo_t;
    Eigen::Isometry3d step = Eigen::Isometry3d::Identity();
    step.linear() = rotation_from_vector(m.twist_w * dt);
    step.translation() = m.twist_v * dt;
    next = m.last_base * step;
  }
  m.add_base_pose(t, next);
  m.twist_v = v;
  m.twist_w = w;
}

void VehicleLocalizer::add_wheel_travel(double t, double left_m, double right_m) {
  std::lock_guard<std::mutex> lk(impl_->m);
  if (!impl_->drive) throw Error("VehicleLocalizer: wheel odometry needs VehicleLocalizerConfig::wheel_base_m > 0");
  impl_->add_base_pose(t, impl_->drive->add(left_m, right_m));
}

void VehicleLocalizer::add_wheel_ticks(double t, std::int64_t left, std::int64_t right) {
  const double k = impl_->cfg.metres_per_tick;
  add_wheel_travel(t, k * static_cast<double>(left), k * static_cast<double>(right));
}

void VehicleLocalizer::add_scan(double t, const Scan& points, const std::vector<std::uint16_t>& rings,
                                const std::vector<float>& point_times) {
  if (!std::isfinite(t)) throw Error("VehicleLocalizer::add_scan: the time is not finite");
  if (!rings.empty() && rings.size() != points.size())
    throw Error("VehicleLocalizer::add_scan: " + std::to_string(rings.size()) + " rings for " + std::to_string(points.size()) +
                " points");
  if (!point_times.empty() && point_times.size() != points.size())
    throw Error("VehicleLocalizer::add_scan: " + std::to_string(point_times.size()) + " point times for " +
                std::to_string(points.size()) + " points");
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->pending = ScanJob{t, points, rings, point_times, {}};  // replaces a scan still waiting
  impl_->cv.notify_all();
}

void VehicleLocalizer::add_gps(double t, const Eigen::Vector3d& antenna_in_map) {
  if (!std::isfinite(t) || !antenna_in_map.allFinite()) throw Error("VehicleLocalizer::add_gps: the fix must be finite");
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->gps.emplace_back(t, antenna_in_map);
  while (impl_->gps.size() > 64) impl_->gps.pop_front();
}

PoseEstimate VehicleLocalizer::pose_at(double t) const {
  PoseEstimate out;
  out.t = t;
  if (!impl_->started) {
    out.note = "not started";
    return out;
  }
  std::lock_guard<std::mutex> lk(impl_->m);
  const Impl& m = *impl_;
  out.valid = true;
  out.base_in_map = m.to_base(m.loc->pose_at(t));
  const FusionConfig& f = m.cfg.localizer.fusion;
  const double intervals = std::max(0.0, (t - m.last_fused_t) / 0.1);
  out.covariance = m.last_cov;
  for (int i = 0; i < 6; ++i) out.covariance(i, i) += intervals * f.odometry_sigma[i] * f.odometry_sigma[i];
  if (m.have_report) {
    out.health = m.last.health;
    out.note = m.last.note;
  } else {
    out.health = Health::Degraded;
    out.note = "no scan registered yet";
  }
  return out;
}

bool VehicleLocalizer::wait_idle(double timeout_s) const {
  std::unique_lock<std::mutex> lk(impl_->m);
  return impl_->cv.wait_for(lk, std::chrono::duration<double>(timeout_s),
                            [&] { return !impl_->pending && !impl_->busy && impl_->request != StartRequest::At; });
}

ScanReport VehicleLocalizer::last_report() const {
  std::lock_guard<std::mutex> lk(impl_->m);
  return impl_->have_report ? impl_->last : ScanReport{};
}

void VehicleLocalizer::on_scan(std::function<void(const ScanReport&)> callback) {
  std::lock_guard<std::mutex> lk(impl_->m);
  impl_->callback = std::move(callback);
}

std::string VehicleLocalizer::last_error() const {
  std::lock_guard<std::mutex> lk(impl_->m);
  return impl_->error;
}

std::vector<MapTile> VehicleLocalizer::map_tiles() const {
  std::unique_lock<std::mutex> lk(impl_->m);
  // The worker changes the ROI map only while busy, and cannot become busy without the lock.
  impl_->cv.wait(lk, [&] { return !impl_->busy; });
  const RoiMap* map = impl_->loc->map();
  return map ? map->held_tiles() : std::vector<MapTile>{};
}

std::vector<schema::TileChangeEvidence> VehicleLocalizer::change_evidence() const {
  std::unique_lock<std::mutex> lk(impl_->m);
  impl_->cv.wait(lk, [&] { return !impl_->busy; });
  return impl_->evidence ? impl_->evidence->tiles() : std::vector<schema::TileChangeEvidence>{};
}

VehicleLocalizer::ChangeStats VehicleLocalizer::change_stats() const {
  std::unique_lock<std::mutex> lk(impl_->m);
  impl_->cv.wait(lk, [&] { return !impl_->busy; });
  ChangeStats out;
  if (!impl_->evidence) return out;
  out.scans = impl_->evidence->scans_used();
  out.skipped = impl_->evidence_skipped;
  out.ms = impl_->evidence->milliseconds();
  return out;
}

double VehicleLocalizer::tile_size() const { return impl_->tile_size; }
GeoPoint VehicleLocalizer::map_origin() const { return impl_->origin; }
std::optional<MapExtent> VehicleLocalizer::map_extent() const {
  std::lock_guard<std::mutex> lk(impl_->m);  // the worker replaces the client when the map's version moves
  return impl_->store ? impl_->store->extent() : impl_->client ? impl_->client->status().extent : std::nullopt;
}
long long VehicleLocalizer::map_version() const { return impl_->version; }
TileClientStatus VehicleLocalizer::tile_status() const {
  std::lock_guard<std::mutex> lk(impl_->m);  // the worker replaces the client when the map's version moves
  return impl_->client ? impl_->client->status() : TileClientStatus{};
}
std::size_t VehicleLocalizer::version_moves() const {
  std::lock_guard<std::mutex> lk(impl_->m);
  return impl_->version_moves;
}

}  // namespace pl::client

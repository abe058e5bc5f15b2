#include "pl/sim/simulate.hpp"

#include <algorithm>
#include <cmath>
#include <atomic>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <thread>
#include <tuple>

#include "pl/common/error.hpp"
#include "pl/common/meta.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/stats.hpp"
#include "pl/common/text.hpp"
#include "pl/sim/lidar.hpp"
#include "pl/sim/output.hpp"

namespace fs = std::filesystem;

namespace pl::sim {

SimTrajectory load_trajectory(const SimOptions& o, std::vector<double>& scan_times) {
  scan_times.clear();
  if (!(o.speed_scale > 0) || !std::isfinite(o.speed_scale)) throw Error("the speed scale must be a positive number");
  SimTrajectory t;
  if (!o.route.empty()) {
    t = builtin_route(o.route);
  } else {
    std::string times = o.times_path.empty() ? find_times_for(o.trajectory_path) : o.times_path;
    t = o.lidar_poses ? trajectory_from_lidar_poses(o.trajectory_path, times) : trajectory_from_kitti(o.trajectory_path, times);
  }
  if (!o.route.empty() || o.speed_scale != 1.0) {
    // Scans every 0.1 s along the (re-timed) path; a pose file's own times when it is driven as recorded.
    if (o.speed_scale != 1.0) t = t.retimed(o.speed_scale);
    for (long long k = 0;; ++k) {
      const double s = t.start_time() + 0.1 * static_cast<double>(k);
      if (s > t.end_time() + 1e-9) break;
      scan_times.push_back(s);
    }
  } else {
    scan_times = t.times();
  }
  if (o.frames > 0) scan_times.resize(std::min<std::size_t>(scan_times.size(), static_cast<std::size_t>(o.frames)));
  return t;
}

namespace {

// The street goes on beyond a drive: the world is built along the path continued straight for
// `beyond` metres before the first scan and after the last, so the first and last scans see a street
// ahead and behind as a real drive does, not the end of the world (closed loops need none).
SimTrajectory street_of(const SimTrajectory& path, double t0, double t1, double beyond) {
  const Pose first = path.pose_at(t0), last = path.pose_at(t1);
  if ((first.translation() - last.translation()).norm() < 30.0) return path;
  std::vector<double> times;
  std::vector<Pose, Eigen::aligned_allocator<Pose>> poses;
  constexpr double kStep = 1.0, kSpeed = 10.0;  // metres between added poses; their (unused) speed
  const auto along = [](const Pose& p, double d) {
    Pose q = p;
    Eigen::Vector3d fwd = p.linear().col(0);
    fwd.z() = 0.0;
    q.translation() += d * fwd.normalized();
    return q;
  };
  for (double d = beyond; d > 0; d -= kStep) {
    times.push_back(t0 - d / kSpeed);
    poses.push_back(along(first, -d));
  }
  times.push_back(t0);
  poses.push_back(first);
  for (std::size_t i = 0; i < path.times().size(); ++i) {
    const double t = path.times()[i];
    if (t <= t0 || t >= t1) continue;
    times.push_back(t);
    poses.push_back(path.poses()[i]);
  }
  times.push_back(t1);
  poses.push_back(last);
  for (double d = kStep; d <= beyond; d += kStep) {
    times.push_back(t1 + d / kSpeed);
    poses.push_back(along(last, d));
  }
  return SimTrajectory(std::move(times), std::move(poses));
}

void write_lines(const std::string& path, const std::string& text) {
  std::unique_ptr<std::FILE, int (*)(std::FILE*)> f(std::fopen(path.c_str(), "w"), &std::fclose);
  if (!f || std::fwrite(text.data(), 1, text.size(), f.get()) != text.size()) throw Error(path + ": write failed");
  if (std::fclose(f.release()) != 0) throw Error(path + ": write failed");
}

// How many rays of the drive see each change: probe rays (every 5th scan, every 4th beam, every
// half degree, up to 40 m: what a vehicle's change evidence uses) cast into both epochs' worlds.
// Where the first returns differ, a return of one epoch with no surface of the other within 0.5 m
// along its normal (the localizer's pair limit: a surface moved less still pairs with its old self,
// and a hedge 10 cm thicker seen at a grazing angle differs in range by metres but is no change)
// counts for the changed thing it lies on. The truth of a map update is what a vehicle could have
// seen: a canopy grown 8 m up, above the sensor's +2 deg, is not.
// `seen` receives, per changed thing (its row) and 1 m cell of the world, the rays that saw it change
// there (at the return of the epoch it changed in).
std::vector<std::uint64_t> rays_seeing(const World& before, const World& after, const std::vector<ObjectChange>& changes,
                                       const LidarModel& lidar, const SimTrajectory& traj, const std::vector<double>& times,
                                       int threads, std::map<std::tuple<std::size_t, int, int>, std::uint64_t>& seen) {
  constexpr float kRange = 40.0f, kTolerance = 0.5f;
  constexpr std::size_t kScanStep = 5, kBeamStep = 4;
  constexpr int kAzimuths = 720;
  std::map<std::uint32_t, std::size_t> index;  // changed thing's id -> its row
  for (std::size_t i = 0; i < changes.size(); ++i) index[changes[i].id] = i;
  Scene s0, s1;
  s0.bvh = Bvh(before.shapes(s0.info));
  s1.bvh = Bvh(after.shapes(s1.info));
  std::vector<std::atomic<std::uint64_t>> count(changes.size());
  std::atomic<std::size_t> next{0};
  std::mutex seen_mutex;
  auto row_of = [&](const Scene& scene, const World& world, const Hit& hit) -> long {
    const auto it = index.find(world.objects[scene.info[scene.bvh.primitives()[hit.primitive].object].object].id);
    return it == index.end() ? -1 : static_cast<long>(it->second);
  };
  auto worker = [&] {
    std::map<std::tuple<std::size_t, int, int>, std::uint64_t> mine;
    auto cell = [&](std::size_t row, const Ray& ray, float t) {
      const Eigen::Vector3f p = ray.origin + t * ray.dir;
      ++mine[{row, static_cast<int>(std::floor(p.x())), static_cast<int>(std::floor(p.y()))}];
    };
    for (std::size_t f = next++ * kScanStep; f < times.size(); f = next++ * kScanStep) {
      const Pose pose = traj.pose_at(times[f]);
      const Eigen::Vector3f origin = pose.translation().cast<float>();
      const Eigen::Matrix3f rot = pose.linear().cast<float>();
      for (std::size_t r = 0; r < lidar.vertical_deg.size(); r += kBeamStep) {
        const double el = lidar.vertical_deg[r] * M_PI / 180.0;
        for (int k = 0; k < kAzimuths; ++k) {
          const double az = 2.0 * M_PI * k / kAzimuths;
          const Eigen::Vector3f d(static_cast<float>(std::cos(el) * std::cos(az)), static_cast<float>(std::cos(el) * std::sin(az)),
                                  static_cast<float>(std::sin(el)));
          Ray ray{origin, rot * d, kRange};
          Hit h0, h1;
          const bool b0 = s0.bvh.intersect(ray, h0), b1 = s1.bvh.intersect(ray, h1);
          if (!b0 && !b1) continue;
          if (b0 && b1 && std::abs(h0.t - h1.t) <= kTolerance) continue;
          // A return of one epoch is a change when the other epoch has no surface near it.
          auto alone = [&](const Scene& other, const Ray& r, const Hit& h) {
            const Eigen::Vector3f p = r.origin + h.t * r.dir;
            for (float side : {1.0f, -1.0f}) {
              Ray probe{p - side * 0.01f * h.normal, side * h.normal, kTolerance};
              Hit ignored;
              if (other.bvh.intersect(probe, ignored)) return false;
            }
            return true;
          };
          const long r0 = b0 ? row_of(s0, before, h0) : -1, r1 = b1 ? row_of(s1, after, h1) : -1;
          const bool gone = r0 >= 0 && alone(s1, ray, h0), come = r1 >= 0 && alone(s0, ray, h1);
          if (gone) cell(static_cast<std::size_t>(r0), ray, h0.t);
          if (come) cell(static_cast<std::size_t>(r1), ray, h1.t);
          if (gone) count[static_cast<std::size_t>(r0)].fetch_add(1, std::memory_order_relaxed);
          if (come && (!gone || r1 != r0)) count[static_cast<std::size_t>(r1)].fetch_add(1, std::memory_order_relaxed);
        }
      }
    }
    std::lock_guard<std::mutex> lock(seen_mutex);
    for (const auto& [k, n] : mine) seen[k] += n;
  };
  std::vector<std::thread> pool;
  for (int k = 0; k < std::max(1, threads); ++k) pool.emplace_back(worker);
  for (auto& th : pool) th.join();
  std::vector<std::uint64_t> out(changes.size());
  for (std::size_t i = 0; i < out.size(); ++i) out[i] = count[i].load();
  return out;
}

}  // namespace

SimReport simulate(const SimOptions& o) {
  auto start = std::chrono::steady_clock::now();
  // Refuse to overwrite a dataset unless told to.
  if (fs::exists(o.out_dir) && !o.force && !fs::is_empty(o.out_dir))
    throw Error(o.out_dir + ": exists and is not empty (choose another --out, or add --force to replace it)");
  LidarModel lidar = lidar_model(o.lidar);
  lidar.fov_deg = o.fov_deg;
  if (!(o.calibration_error >= 0)) throw Error("the calibration error scale must be 0 or more");
  if (!(o.truth.scale >= 0) || !std::isfinite(o.truth.scale)) throw Error("the truth error scale must be 0 or more");
  // The sensor's own errors: one set per sensor (seed), the same in every epoch and drive of it.
  lidar.laser_errors = draw_laser_errors(lidar.vertical_deg.size(), o.calibration_error, o.world.seed);
  const std::uint64_t drive_seed = o.drive_seed < 0 ? o.world.seed : static_cast<std::uint64_t>(o.drive_seed);
  GpsConfig gps_cfg = o.gps;
  if (!o.gnss_profile.empty()) gps_cfg.profile = read_gnss_profile(o.gnss_profile);

  std::vector<double> scan_times;
  const SimTrajectory route = load_trajectory(o, scan_times);
  if (scan_times.size() < 2) throw Error("the drive needs at least two scans");
  // The world comes from the forward route's stretch alone, whichever way it is driven.
  const SimTrajectory street = street_of(route, scan_times.front(), scan_times.back(), 80.0);
  // --reverse: the same stretch from its end back to its start, the scans at the same places.
  const SimTrajectory traj = o.reverse ? route.reversed() : route;
  if (o.reverse) {
    std::reverse(scan_times.begin(), scan_times.end());
    for (double& t : scan_times) t = route.start_time() + route.end_time() - t;
  }
  const double t0 = scan_times.front(), t1 = scan_times.back();
  World world = build_world(street, street.start_time(), street.end_time(), o.world);
  Scene scene;
  scene.bvh = Bvh(world.shapes(scene.info));
  TrafficConfig tcfg = o.traffic;
  tcfg.seed = drive_seed;
  tcfg.road_half_width = o.world.road_half_width;
  Traffic traffic(traj, t0, t1, tcfg);

  fs::path out(o.out_dir);
  fs::path tmp = out.parent_path() / (out.filename().string() + ".partial");
  fs::remove_all(tmp);
  fs::create_directories(tmp / "velodyne");
  if (o.sweep) fs::create_directories(tmp / "point_times");
  constexpr double kSweep = 0.1;  // seconds a turn (10 Hz)

  // Scans in parallel; each frame's noise comes from its own seed, so threads do not change a byte.
  const std::size_t n = scan_times.size();
  int threads = o.threads > 0 ? o.threads : static_cast<int>(std::max(1u, std::thread::hardware_concurrency()));
  threads = static_cast<int>(std::min<std::size_t>(static_cast<std::size_t>(threads), n));
  std::vector<std::size_t> counts(n, 0);
  // Per thing, this drive: returns (low 32 bits) and those within kNear of the sensor (high 32 bits).
  constexpr float kNear = 40.0f;
  std::vector<std::atomic<std::uint64_t>> returns(world.objects.size());
  std::atomic<std::size_t> next{0}, done{0};
  std::exception_ptr failure;
  std::mutex failure_mutex;
  Progress progress("simulating scans", n);
  auto worker = [&] {
    try {
      for (std::size_t i = next++; i < n; i = next++) {
        double t = scan_times[i];
        Pose pose = traj.pose_at(t);
        std::mt19937_64 rng(drive_seed * 0x9E3779B97F4A7C15ull ^ (static_cast<std::uint64_t>(i) * 0xBF58476D1CE4E5B9ull) ^
                            static_cast<std::uint64_t>(o.world.epoch + 1) * 0x94D049BB133111EBull);
        std::unique_ptr<Scene> moving;
        if (traffic.size()) moving = std::make_unique<Scene>(traffic.scene_at(t, pose.translation(), lidar.max_range));
        std::vector<float> shares;
        std::vector<std::uint32_t> hit;
        Scan scan = cast_sweep(lidar, [&](double share) { return o.sweep ? traj.pose_at(t + share * kSweep) : pose; }, scene,
                               moving.get(), rng, &shares, &hit);
        for (std::size_t k = 0; k < hit.size(); ++k) {
          if (hit[k] == kTraffic) continue;
          const PointXYZI& p = scan[k];
          const bool near = p.x * p.x + p.y * p.y + p.z * p.z <= kNear * kNear;
          returns[hit[k]].fetch_add(near ? (std::uint64_t{1} << 32) | 1 : 1, std::memory_order_relaxed);
        }
        char name[32];
        std::snprintf(name, sizeof(name), "%06zu.bin", i);
        write_kitti_bin((tmp / "velodyne" / name).string(), scan);
        if (o.sweep) {
          for (float& s : shares) s = static_cast<float>(s * kSweep);
          write_point_times((tmp / "point_times" / name).string(), shares);
        }
        counts[i] = scan.size();
        progress.update(++done);
      }
    } catch (...) {
      std::lock_guard<std::mutex> lock(failure_mutex);
      if (!failure) failure = std::current_exception();
      next = n;
    }
  };
  std::vector<std::thread> pool;
  for (int k = 0; k < threads; ++k) pool.emplace_back(worker);
  for (auto& th : pool) th.join();
  progress.finish();
  if (failure) std::rethrow_exception(failure);

  // Ground truth and times.
  std::string times_txt, poses_txt;
  char buf[512];
  std::vector<Pose, Eigen::aligned_allocator<Pose>> truth;
  for (double t : scan_times) truth.push_back(traj.pose_at(t));
  truth = ins_truth(truth, scan_times, o.truth, drive_seed + 1000003ull * static_cast<std::uint64_t>(o.world.epoch));
  for (std::size_t i = 0; i < scan_times.size(); ++i) {
    std::snprintf(buf, sizeof(buf), "%.6f\n", scan_times[i] - t0);
    times_txt += buf;
    const auto m = truth[i].matrix();
    std::snprintf(buf, sizeof(buf), "%.9f %.9f %.9f %.6f %.9f %.9f %.9f %.6f %.9f %.9f %.9f %.6f\n", m(0, 0), m(0, 1),
                  m(0, 2), m(0, 3), m(1, 0), m(1, 1), m(1, 2), m(1, 3), m(2, 0), m(2, 1), m(2, 2), m(2, 3));
    poses_txt += buf;
  }
  write_lines((tmp / "times.txt").string(), times_txt);
  write_lines((tmp / "poses.txt").string(), poses_txt);

  // Wheel encoders and GPS.
  auto encoder = simulate_encoder(traj, t0, t1, o.encoder);
  std::string enc = "t,left_m,right_m\n";
  for (const auto& e : encoder) {
    std::snprintf(buf, sizeof(buf), "%.4f,%.6f,%.6f\n", e.t, e.left_m, e.right_m);
    enc += buf;
  }
  write_lines((tmp / "encoder.csv").string(), enc);
  EnuFrame enu(o.origin);
  std::mt19937_64 gps_rng(drive_seed * 0x2545F4914F6CDD1Dull + 0x6B5);
  auto gps = simulate_gps(traj, t0, t1, world, enu, gps_cfg, gps_rng);
  std::string g = "t,lat,lon,alt,std_m,status\n";
  std::map<std::string, std::size_t> mix;
  for (const auto& f : gps) {
    std::snprintf(buf, sizeof(buf), "%.4f,%.10f,%.10f,%.4f,%.4f,%d\n", f.t, f.position.lat_deg, f.position.lon_deg,
                  f.position.alt_m, f.std_m, f.status);
    g += buf;
    ++mix[gps_status_name(f.status)];
  }
  write_lines((tmp / "gps.csv").string(), g);

  DatasetMeta meta;
  meta.sensor.model = lidar.model;
  meta.sensor.beams = static_cast<int>(lidar.vertical_deg.size());
  meta.sensor.vertical_angles_deg = lidar.vertical_deg;
  meta.sensor.point_order = "laser-by-laser";
  meta.sensor.fov_deg = lidar.fov_deg;
  meta.sensor.rate_hz = 10.0;
  meta.sensor.max_range_m = lidar.max_range;
  meta.vehicle.wheel_base_m = o.encoder.wheel_base;
  meta.vehicle.gps_lever_arm = gps_cfg.lever_arm;
  meta.origin = o.origin;
  write_meta((tmp / "meta.json").string(), meta);

  // The things of the world and what changed: the truth a map update is judged by.
  std::vector<std::uint64_t> returned(returns.size()), near(returns.size());
  for (std::size_t i = 0; i < returns.size(); ++i) {
    returned[i] = returns[i].load() & 0xFFFFFFFFu;
    near[i] = returns[i].load() >> 32;
  }
  write_lines((tmp / "objects.csv").string(), objects_csv(world, returned, near));
  SimReport r;
  if (o.world.epoch >= 1) {
    WorldConfig before = o.world;
    before.epoch = 0;
    const World world0 = build_world(street, street.start_time(), street.end_time(), before);
    const std::vector<ObjectChange> changes = changes_between(world0, world);
    std::map<std::tuple<std::size_t, int, int>, std::uint64_t> seen;
    write_lines((tmp / "changes.csv").string(), changes_csv(changes, rays_seeing(world0, world, changes, lidar, traj, scan_times, threads, seen)));
    std::string text = "id,x,y,rays\n";
    for (const auto& [k, n] : seen) {
      const auto& [row, cx, cy] = k;
      std::snprintf(buf, sizeof buf, "%u,%.1f,%.1f,%llu\n", changes[row].id, cx + 0.5, cy + 0.5, static_cast<unsigned long long>(n));
      text += buf;
    }
    write_lines((tmp / "changes_seen.csv").string(), text);
    r.changes = changes.size();
  }

  // Publish: the finished folder replaces the old one in one rename.
  if (fs::exists(out)) fs::remove_all(out);
  fs::rename(tmp, out);

  if (!o.preview.empty()) write_preview(o.preview, world, traj, t0, t1, &traffic);
  if (!o.map_out.empty()) {
    std::vector<float> intensity;
    Points3d cloud = sample_world(world, o.map_spacing, intensity);
    write_pcd(o.map_out, cloud, intensity, o.origin);  // the frame of the drive: its geodetic origin
    r.map_points = cloud.size();
  }
  r.frames = n;
  r.objects = world.objects.size();
  for (const auto& obj : world.objects) r.movable += is_movable(obj.cls);
  auto [fewest, most] = std::minmax_element(counts.begin(), counts.end());
  r.points_min = *fewest;
  r.points_median = median(std::vector<double>(counts.begin(), counts.end()));
  r.points_max = *most;
  r.encoder_samples = encoder.size();
  r.gps_fixes = gps.size();
  for (const auto& [name, count] : mix) {
    std::snprintf(buf, sizeof(buf), "%s%s %.0f %%", r.gps_mix.empty() ? "" : ", ", name.c_str(),
                  100.0 * static_cast<double>(count) / std::max<std::size_t>(1, gps.size()));
    r.gps_mix += buf;
  }
  if (r.gps_mix.empty()) r.gps_mix = "none";
  r.length_m = traj.distance_at(t1) - traj.distance_at(t0);
  r.duration_s = t1 - t0;
  r.max_speed_mps = traj.max_speed();
  r.threads = threads;
  r.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return r;
}

}  // namespace pl::sim

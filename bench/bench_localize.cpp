// Registration on the paper's protocol on a real drive: the odd-numbered scans of a KITTI raw drive
// localized with 16 of their 64 beams against the map of its even-numbered scans, each method in its
// own loop on its own estimates (start: the first odd scan's ground-truth pose; prediction: constant
// velocity from the method's previous estimates, no odometry), one thread, all methods advanced scan
// by scan in the same run so that their timings share the machine's state.
//   ours                    pl::client::Localizer, default LocalizerConfig
//   ours from ground truth  the same, restarted at every scan's ground-truth pose (the accuracy floor)
//   pcl ICP point-to-point  pcl::IterativeClosestPoint on the map points within 60 m of the prediction
//   pcl ICP point-to-plane  pcl::IterativeClosestPointWithNormals, the tiles' normals on the map
//   pcl NDT                 pcl::NormalDistributionsTransform on the same map points
// With --from-truth, instead, the floors only: ours, PCL's ICP and GICP restarted at every scan's
// ground-truth pose, and ours and PCL's ICP restarted 0.2 m from it (horizontally, a direction turning
// by the golden angle from scan to scan): a method whose result depends on where it starts looks
// better from the truth than it is. (A run of its own: GICP's per-scan covariances of the target take
// seconds a scan and would disturb the timings of the others.)
// Errors are the translation error of each scan's estimate against its ground-truth pose (no
// alignment). The benchmark reports; it never fails on a figure.
//   bench_localize DATASET_DIR MAPS.sqlite [--map NAME] [--quick N] [--every K [--phase P]] [--ndt-eps E] [--from-truth] [--ours-only] [--per-scan CSV] [--set NAME=VALUE]...
// (--every K --phase P: every K-th odd scan from the P-th, one of the K drives interleaved in the recording)
#include <pcl/point_cloud.h>
#include <pcl/point_types.h>
#include <pcl/registration/gicp.h>
#include <pcl/registration/icp.h>
#include <pcl/registration/ndt.h>
#include <pcl/search/kdtree.h>

#include <Eigen/Geometry>
#include <unistd.h>

#include <cmath>
#include <fstream>
#include <stdexcept>
#include <cstdio>
#include <cstdlib>
#include <exception>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "bench_util.hpp"
#include "pl/client/config_fields.hpp"
#include "pl/client/localizer.hpp"
#include "pl/client/store_tiles.hpp"
#include "pl/common/scan.hpp"
#include "pl/recordings/dataset.hpp"

namespace {

using Isometry = Eigen::Isometry3d;
using Poses = std::vector<Isometry, Eigen::aligned_allocator<Isometry>>;
using pl::bench::now_ms;

// One method's run: its estimates and timings, one entry per localized scan.
struct Run {
  std::string name, settings;
  Poses poses;
  std::vector<double> register_ms;  // the registration alone
  std::vector<double> target_ms;    // gathering the map points around the prediction (PCL)
  std::vector<double> index_ms;     // building the target's search structure (k-d tree, NDT cells)
  std::vector<double> map_ms;       // ours: bringing the ROI map up to date
  std::vector<int> ok;              // the method's own verdict: accepted (ours) or converged (PCL)
  std::vector<int> iterations;
  std::vector<double> points, target_points;  // scan points registered, map points in the target
  int lost = 0, degraded = 0;
};

// Constant velocity from the run's last two estimates (the previous one alone after the first scan,
// the start pose for the first).
Isometry predict(const Run& run, const std::vector<double>& times, std::size_t k, const Isometry& start) {
  if (k == 0) return start;
  const Isometry& last = run.poses[k - 1];
  if (k == 1) return last;
  const Isometry& prev = run.poses[k - 2];
  const double dt = times[k - 1] - times[k - 2];
  const double f = dt > 0 ? (times[k] - times[k - 1]) / dt : 1.0;
  const Isometry d = prev.inverse() * last;
  const Eigen::AngleAxisd aa(d.linear());
  Isometry step = Isometry::Identity();
  step.linear() = Eigen::AngleAxisd(f * aa.angle(), aa.axis()).toRotationMatrix();
  step.translation() = f * d.translation();
  return last * step;
}

// The map points within `radius` (horizontally) of `center`, as float offsets from `anchor`; with
// the tiles' normals for PointNormal.
template <typename PointT>
typename pcl::PointCloud<PointT>::Ptr gather(pl::client::StoreTiles& store, const Eigen::Vector3d& center, double radius,
                                             const Eigen::Vector3d& anchor) {
  typename pcl::PointCloud<PointT>::Ptr cloud(new pcl::PointCloud<PointT>);
  const double r2 = radius * radius;
  for (const auto& tile : store.near(center.head<2>(), radius)) {
    const pl::TileCloud& c = *tile.cloud;
    for (std::size_t i = 0; i < c.points.size(); ++i) {
      if ((c.points[i] - center).head<2>().squaredNorm() > r2) continue;
      const Eigen::Vector3f p = (c.points[i] - anchor).cast<float>();
      PointT q;
      q.x = p.x(), q.y = p.y(), q.z = p.z();
      if constexpr (std::is_same_v<PointT, pcl::PointNormal>) {
        if (c.normals.size() != c.points.size()) continue;
        q.normal_x = c.normals[i].x(), q.normal_y = c.normals[i].y(), q.normal_z = c.normals[i].z();
        q.curvature = 0.f;
      }
      cloud->push_back(q);
    }
  }
  return cloud;
}

template <typename PointT>
typename pcl::PointCloud<PointT>::Ptr to_pcl(const pl::Scan& scan) {
  typename pcl::PointCloud<PointT>::Ptr cloud(new pcl::PointCloud<PointT>);
  cloud->reserve(scan.size());
  for (const auto& p : scan) {
    PointT q;
    q.x = p.x, q.y = p.y, q.z = p.z;
    if constexpr (std::is_same_v<PointT, pcl::PointNormal>) q.normal_x = q.normal_y = q.normal_z = q.curvature = 0.f;
    cloud->push_back(q);
  }
  return cloud;
}

// Anchor-relative float transform <-> map-frame double pose.
Eigen::Matrix4f to_local(const Isometry& pose, const Eigen::Vector3d& anchor) {
  Isometry local = pose;
  local.translation() -= anchor;
  return local.matrix().cast<float>();
}
Isometry from_local(const Eigen::Matrix4f& m, const Eigen::Vector3d& anchor) {
  Isometry pose(m.cast<double>());
  // Re-orthonormalize the float rotation.
  pose.linear() = Eigen::Quaterniond(pose.linear()).normalized().toRotationMatrix();
  pose.translation() += anchor;
  return pose;
}

// One PCL ICP step (point-to-point or point-to-plane): target gathered around the prediction, its
// k-d tree built (timed apart), then align from the prediction.
template <typename PointT, typename Icp>
void icp_step(Icp& icp, Run& run, pl::client::StoreTiles& store, const typename pcl::PointCloud<PointT>::Ptr& source,
              const Isometry& pred, const Eigen::Vector3d& anchor, double radius) {
  double t0 = now_ms();
  auto target = gather<PointT>(store, pred.translation(), radius, anchor);
  double t1 = now_ms();
  typename pcl::search::KdTree<PointT>::Ptr tree(new pcl::search::KdTree<PointT>);
  tree->setInputCloud(target);
  double t2 = now_ms();
  icp.setInputSource(source);
  icp.setInputTarget(target);
  icp.setSearchMethodTarget(tree, true);  // built above: align() must not build it again
  pcl::PointCloud<PointT> aligned;
  icp.align(aligned, to_local(pred, anchor));
  double t3 = now_ms();
  run.target_ms.push_back(t1 - t0);
  run.index_ms.push_back(t2 - t1);
  run.register_ms.push_back(t3 - t2);
  const auto state = icp.getConvergeCriteria()->getConvergenceState();
  using CC = pcl::registration::DefaultConvergenceCriteria<float>;
  run.ok.push_back(state == CC::CONVERGENCE_CRITERIA_TRANSFORM || state == CC::CONVERGENCE_CRITERIA_ABS_MSE ||
                   state == CC::CONVERGENCE_CRITERIA_REL_MSE);
  run.iterations.push_back(0);
  run.points.push_back(static_cast<double>(source->size()));
  run.target_points.push_back(static_cast<double>(target->size()));
  run.poses.push_back(target->empty() ? pred : from_local(icp.getFinalTransformation(), anchor));
}

struct ApeStats {
  double mean = 0, median = 0, rmse = 0, max = 0;
  std::size_t within = 0;  // scans within 0.5 m
  std::size_t worst = 0;   // index of the largest error
  long first_off = -1;     // first scan more than 1 m off
};

ApeStats ape(const Poses& est, const Poses& gt) {
  ApeStats s;
  std::vector<double> e;
  for (std::size_t k = 0; k < est.size(); ++k) {
    const double err = (est[k].translation() - gt[k].translation()).norm();
    e.push_back(err);
    s.mean += err;
    s.rmse += err * err;
    if (err > s.max) s.max = err, s.worst = k;
    if (err <= 0.5) ++s.within;
    if (err > 1.0 && s.first_off < 0) s.first_off = static_cast<long>(k);
  }
  if (e.empty()) return s;
  s.mean /= static_cast<double>(e.size());
  s.rmse = std::sqrt(s.rmse / static_cast<double>(e.size()));
  s.median = pl::median(e);
  return s;
}

double sum_of(const std::vector<double>& a, std::size_t k) { return k < a.size() ? a[k] : 0.0; }

// Median over scans of the whole per-scan cost: map upkeep + target + index + registration.
double per_scan_median(const Run& r) {
  std::vector<double> v;
  for (std::size_t k = 0; k < r.register_ms.size(); ++k)
    v.push_back(r.register_ms[k] + sum_of(r.target_ms, k) + sum_of(r.index_ms, k) + sum_of(r.map_ms, k));
  return v.empty() ? 0.0 : pl::median(v);
}

}  // namespace

int main(int argc, char** argv) try {
  std::string dir, db, map_name = "k05", per_scan;
  std::size_t quick = 0, every = 1, phase = 0;
  double ndt_eps = 1e-4;
  bool from_truth = false, ours_only = false;
  std::vector<std::string> settings;  // localizer settings by name, as pl-localize --set takes them
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--from-truth")
      from_truth = true;
    else if (a == "--map" && i + 1 < argc)
      map_name = argv[++i];
    else if (a == "--quick" && i + 1 < argc)
      quick = static_cast<std::size_t>(std::stoul(argv[++i]));
    else if (a == "--every" && i + 1 < argc)
      every = std::max<std::size_t>(1, static_cast<std::size_t>(std::stoul(argv[++i])));
    else if (a == "--phase" && i + 1 < argc)
      phase = static_cast<std::size_t>(std::stoul(argv[++i]));
    else if (a == "--ours-only")
      ours_only = true;
    else if (a == "--set" && i + 1 < argc)
      settings.emplace_back(argv[++i]);
    else if (a == "--per-scan" && i + 1 < argc)
      per_scan = argv[++i];
    else if (a == "--ndt-eps" && i + 1 < argc)
      ndt_eps = std::stod(argv[++i]);
    else if (dir.empty())
      dir = a;
    else if (db.empty())
      db = a;
    else {
      std::fprintf(stderr, "usage: bench_localize DATASET_DIR MAPS.sqlite [--map NAME] [--quick N] [--every K [--phase P]] [--ndt-eps E] [--from-truth] [--ours-only] [--per-scan CSV] [--set NAME=VALUE]...\n");
      return 2;
    }
  }
  if (dir.empty() || db.empty()) {
    std::fprintf(stderr, "usage: bench_localize DATASET_DIR MAPS.sqlite [--map NAME] [--quick N] [--every K [--phase P]] [--ndt-eps E] [--from-truth] [--ours-only] [--per-scan CSV] [--set NAME=VALUE]...\n");
    return 2;
  }

  if (phase >= every) {
    std::fprintf(stderr, "bench_localize: --phase %zu must be below --every %zu\n", phase, every);
    return 2;
  }
  const pl::Dataset ds = pl::open_dataset(dir);
  if (!ds.has_ground_truth()) {
    std::fprintf(stderr, "bench_localize: %s has no ground truth\n", dir.c_str());
    return 2;
  }
  std::vector<std::size_t> scans;  // the odd-numbered frames (every K-th of them: the drive K times faster)
  for (std::size_t i = 0, odd = 0; i < ds.size(); ++i) {
    const long f = ds.frame_ids.empty() ? static_cast<long>(i) : ds.frame_ids[i];
    if (f % 2 == 1 && odd++ % every == phase) scans.push_back(i);
  }
  if (quick > 0 && quick < scans.size()) scans.resize(quick);
  if (scans.size() < 2) {
    std::fprintf(stderr, "bench_localize: fewer than two odd scans\n");
    return 2;
  }
  std::vector<double> times;
  Poses gt;
  for (std::size_t i : scans) times.push_back(ds.times[i]), gt.push_back(ds.ground_truth.poses[i]);
  const Isometry start = gt.front();
  const Eigen::Vector3d anchor = start.translation();  // PCL's float coordinates are offsets from here

  pl::client::StoreTiles store(db, map_name);
  const pl::client::TileProvider provider = [&store](const Eigen::Vector2d& c, double r) { return store.near(c, r); };
  const int sensor_beams = ds.meta.sensor.beams > 0 ? ds.meta.sensor.beams : 64;

  // Ours.
  pl::client::LocalizerConfig cfg;
  cfg.scan.beams = 16;
  cfg.scan.sensor_beams = sensor_beams;
  if (!settings.empty()) {  // the names pl-localize --list-settings prints ("localizer/icp/kernel_m=0.3")
    pl::client::VehicleLocalizerConfig vc;
    vc.localizer = cfg;
    for (const std::string& kv : settings) {
      const std::size_t eq = kv.find('=');
      if (eq == std::string::npos) throw std::runtime_error("--set takes NAME=VALUE, not \"" + kv + "\"");
      pl::client::set_config_field(vc, kv.substr(0, eq), kv.substr(eq + 1));
    }
    cfg = vc.localizer;
  }
  pl::client::Localizer ours_loc(cfg, store.tile_size(), provider);
  pl::client::Localizer floor_loc(cfg, store.tile_size(), provider);
  Run ours, floor, icp_pp, icp_pl, ndt, icp_gt, gicp_gt, floor_off, icp_off, gicp_off;
  pl::client::Localizer off_loc(cfg, store.tile_size(), provider);
  char buf[512];
  std::snprintf(buf, sizeof buf,
                "default LocalizerConfig: 16 of %d beams, %.1f m voxels, range %.0f m, ROI %.0f m, cells %.2f m, "
                "pairs <= %.1f m, kernel %.2f m, <= %d iterations, momentum over %d scans (%.1f s in the ground plane)",
                sensor_beams, cfg.scan.voxel_m, cfg.scan.max_range_m, cfg.roi_radius_m, cfg.map.cell_m, cfg.icp.max_pair_m,
                cfg.icp.kernel_m, cfg.icp.max_iterations, cfg.fusion.momentum_window, cfg.fusion.momentum_plane_s);
  ours.name = "ours (pl::client::Localizer)";
  ours.settings = buf;
  floor.name = "ours, each scan from its ground truth";
  floor.settings = "the same, restarted at every scan's ground-truth pose; its registration result";

  // PCL: the same 16-beam scan at 0.2 m voxels, the map points within 60 m of the prediction.
  pl::ScanPrepConfig prep;
  prep.beams = 16;
  prep.sensor_beams = sensor_beams;
  prep.voxel_m = 0.2;
  prep.max_range_m = 80.0;
  const double target_radius = 60.0;
  const int pcl_iterations = 50;
  const double max_corr = 1.0;

  pcl::IterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> icp;
  icp.setMaxCorrespondenceDistance(max_corr);
  icp.setMaximumIterations(pcl_iterations);
  icp.setTransformationEpsilon(1e-6);
  icp.setEuclideanFitnessEpsilon(1e-6);
  icp_pp.name = "pcl ICP point-to-point";
  icp_pp.settings = "pcl::IterativeClosestPoint<PointXYZ>: max correspondence 1.0 m, 50 iterations, "
                    "transformation eps 1e-6, euclidean fitness eps 1e-6";

  pcl::IterativeClosestPointWithNormals<pcl::PointNormal, pcl::PointNormal> icpn;
  icpn.setMaxCorrespondenceDistance(max_corr);
  icpn.setMaximumIterations(pcl_iterations);
  icpn.setTransformationEpsilon(1e-6);
  icpn.setEuclideanFitnessEpsilon(1e-6);
  icp_pl.name = "pcl ICP point-to-plane";
  icp_pl.settings = "pcl::IterativeClosestPointWithNormals<PointNormal> (point-to-plane LLS), map normals = tile normals, "
                    "same limits";

  pcl::NormalDistributionsTransform<pcl::PointXYZ, pcl::PointXYZ> nd;
  nd.setResolution(1.0f);
  nd.setStepSize(0.1);
  nd.setTransformationEpsilon(ndt_eps);
  nd.setMaximumIterations(pcl_iterations);
  // NDT never uses the registration's k-d tree over the target: keep align() from building one.
  nd.setSearchMethodTarget(pcl::search::KdTree<pcl::PointXYZ>::Ptr(new pcl::search::KdTree<pcl::PointXYZ>), true);
  std::snprintf(buf, sizeof buf,
                "pcl::NormalDistributionsTransform<PointXYZ>: resolution 1.0 m, step 0.1, transformation eps %g "
                "(PCL 1.13 compares it with the squared translation of a step: stops below %.3g m; 0.01 would stop once a "
                "step is under 0.1 m, i.e. about at once), 50 iterations",
                ndt_eps, std::sqrt(ndt_eps));
  ndt.name = "pcl NDT";
  ndt.settings = buf;

  // The floors of PCL's ICP and GICP: each scan registered from its ground-truth pose.
  pcl::GeneralizedIterativeClosestPoint<pcl::PointXYZ, pcl::PointXYZ> gicp;
  gicp.setMaxCorrespondenceDistance(max_corr);
  gicp.setMaximumIterations(pcl_iterations);
  gicp.setTransformationEpsilon(1e-3);  // GICP compares each step's translation with it directly: 1 mm, as ICP's 1e-6 squared
  icp_gt.name = "pcl ICP from ground truth";
  icp_gt.settings = "the point-to-point ICP above, restarted at every scan's ground-truth pose";
  floor_off.name = "ours from ground truth + 0.2 m";
  floor_off.settings = "ours, restarted 0.2 m from every scan's ground-truth pose (horizontal, golden-angle directions)";
  icp_off.name = "pcl ICP from ground truth + 0.2 m";
  icp_off.settings = "the point-to-point ICP, restarted from the same shifted poses";
  gicp_off.name = "pcl GICP from ground truth + 0.2 m";
  gicp_off.settings = "the GICP, restarted from the same shifted poses";
  gicp_gt.name = "pcl GICP from ground truth";
  gicp_gt.settings = "pcl::GeneralizedIterativeClosestPoint<PointXYZ>: covariances from 20 neighbours (its default), "
                     "max correspondence 1.0 m, 50 iterations, transformation eps 1e-3 (a 1 mm step; ICP's 1e-6 is "
                     "squared), rotation eps its default; restarted at every scan's ground-truth pose";

  std::printf("drive %s: %zu odd scans (frames %ld..%ld) localized against map '%s' v%lld of the even scans\n",
              dir.c_str(), scans.size(), ds.frame_ids.empty() ? static_cast<long>(scans.front()) : ds.frame_ids[scans.front()],
              ds.frame_ids.empty() ? static_cast<long>(scans.back()) : ds.frame_ids[scans.back()], map_name.c_str(),
              store.version());
  std::printf("start: the ground-truth pose of the first odd scan; prediction: constant velocity from each method's own "
              "estimates (no odometry); one thread; methods interleaved scan by scan\n");
  std::printf("PCL inputs: the scan with 16 of %d beams, range 2..80 m, 0.2 m voxels; target: the map points within "
              "%.0f m of the prediction (floats relative to an anchor at the start), rebuilt every scan\n",
              sensor_beams, target_radius);
  std::fflush(stdout);

  const bool progress = ::isatty(STDERR_FILENO) && !std::getenv("PL_NO_PROGRESS");
  for (std::size_t k = 0; k < scans.size(); ++k) {
    const std::size_t i = scans[k];
    const double t = times[k];
    const pl::Frame frame = ds.load_frame(i);
    const pl::Scan& raw = frame.scan;
    const auto& rings = frame.rings;

    // Ours.
    if (k == 0) ours_loc.start(start, t, nullptr);
    if (!from_truth) {
      const pl::client::ScanReport r = ours_loc.process(t, raw, rings);
      ours.poses.push_back(r.fused);
      ours.register_ms.push_back(r.register_ms);
      ours.map_ms.push_back(r.map_ms);
      ours.ok.push_back(r.fused_lidar);
      ours.iterations.push_back(r.icp.iterations);
      ours.points.push_back(static_cast<double>(r.scan_points));
      ours.target_points.push_back(static_cast<double>(r.map_points));
      ours.lost += r.health == pl::client::Health::Lost;
      ours.degraded += r.health == pl::client::Health::Degraded;
    }
    // Ours from the ground truth.
    {
      floor_loc.start(gt[k], t, nullptr);
      const pl::client::ScanReport r = floor_loc.process(t, raw, rings);
      floor.poses.push_back(r.icp.pose);
      floor.register_ms.push_back(r.register_ms);
      floor.map_ms.push_back(r.map_ms);
      floor.ok.push_back(r.icp.accepted);
      floor.iterations.push_back(r.icp.iterations);
    }

    // Ours 0.2 m from the ground truth (horizontally, the direction turning by the golden angle).
    const double a = 2.399963229728653 * static_cast<double>(k);
    Isometry shifted = gt[k];
    shifted.translation() += 0.2 * Eigen::Vector3d(std::cos(a), std::sin(a), 0.0);
    if (from_truth) {
      off_loc.start(shifted, t, nullptr);
      const pl::client::ScanReport r = off_loc.process(t, raw, rings);
      floor_off.poses.push_back(r.icp.pose);
      floor_off.register_ms.push_back(r.register_ms);
      floor_off.ok.push_back(r.icp.accepted);
    }

    // PCL.
    if (ours_only) continue;
    const pl::Scan prepared = pl::prepare_scan(raw, rings, prep);
    const auto src_xyz = to_pcl<pcl::PointXYZ>(prepared);
    const auto src_n = to_pcl<pcl::PointNormal>(prepared);
    if (!from_truth) {
      icp_step<pcl::PointXYZ>(icp, icp_pp, store, src_xyz, predict(icp_pp, times, k, start), anchor, target_radius);
      icp_step<pcl::PointNormal>(icpn, icp_pl, store, src_n, predict(icp_pl, times, k, start), anchor, target_radius);
    }
    if (!from_truth) {
      const Isometry pred = predict(ndt, times, k, start);
      double t0 = now_ms();
      auto target = gather<pcl::PointXYZ>(store, pred.translation(), target_radius, anchor);
      double t1 = now_ms();
      nd.setInputTarget(target);  // builds the NDT cells (and their k-d tree)
      double t2 = now_ms();
      nd.setInputSource(src_xyz);
      pcl::PointCloud<pcl::PointXYZ> aligned;
      nd.align(aligned, to_local(pred, anchor));
      double t3 = now_ms();
      ndt.points.push_back(static_cast<double>(src_xyz->size()));
      ndt.target_points.push_back(static_cast<double>(target->size()));
      ndt.target_ms.push_back(t1 - t0);
      ndt.index_ms.push_back(t2 - t1);
      ndt.register_ms.push_back(t3 - t2);
      ndt.ok.push_back(nd.hasConverged() && nd.getFinalNumIteration() < pcl_iterations);
      ndt.iterations.push_back(nd.getFinalNumIteration());
      ndt.poses.push_back(from_local(nd.getFinalTransformation(), anchor));
    }
    if (from_truth) {
      icp_step<pcl::PointXYZ>(icp, icp_gt, store, src_xyz, gt[k], anchor, target_radius);
      icp_step<pcl::PointXYZ>(gicp, gicp_gt, store, src_xyz, gt[k], anchor, target_radius);
      gicp_gt.ok.back() = gicp.hasConverged();  // GICP does not report through the convergence criteria
      icp_step<pcl::PointXYZ>(icp, icp_off, store, src_xyz, shifted, anchor, target_radius);
      icp_step<pcl::PointXYZ>(gicp, gicp_off, store, src_xyz, shifted, anchor, target_radius);
      gicp_off.ok.back() = gicp.hasConverged();
    }
    if (progress && ((k + 1) % 10 == 0 || k + 1 == scans.size())) {
      std::fprintf(stderr, "  %zu / %zu scans\n", k + 1, scans.size());
      std::fflush(stderr);
    }
  }

  const std::size_t n = scans.size();
  if (!from_truth && !ours_only)
    std::printf("points a scan (medians): ours registers %.0f (%.1f m voxels) against its ROI map of %.0f; PCL registers %.0f "
              "(0.2 m voxels) against %.0f\n\n",
              pl::median(ours.points), cfg.scan.voxel_m, pl::median(ours.target_points),
              pl::median(icp_pp.points), pl::median(icp_pp.target_points));

  std::printf("%-40s %7s %7s %7s %7s  %8s %7s  %9s %8s  %9s %9s\n", "APE vs OXTS (m), registration (ms)", "mean", "median",
              "RMSE", "max", "coverage", "<0.5 m", "reg p50", "reg p99", "target", "index");
  const std::vector<const Run*> runs =
      ours_only ? (from_truth ? std::vector<const Run*>{&floor, &floor_off} : std::vector<const Run*>{&ours, &floor})
      : from_truth ? std::vector<const Run*>{&floor, &floor_off, &icp_gt, &icp_off, &gicp_gt, &gicp_off}
                   : std::vector<const Run*>{&ours, &floor, &icp_pp, &icp_pl, &ndt};
  const auto ms_or_dash = [](const std::vector<double>& v) {
    char b[32] = "-";
    if (!v.empty()) std::snprintf(b, sizeof b, "%.2f", pl::median(v));
    return std::string(b);
  };
  for (const Run* r : runs) {
    const ApeStats s = ape(r->poses, gt);
    std::size_t ok = 0;
    for (int v : r->ok) ok += v > 0;
    std::printf("%-40s %7.3f %7.3f %7.3f %7.3f  %7.1f%% %6.1f%%  %9.2f %8.2f  %9s %9s\n", r->name.c_str(), s.mean, s.median,
                s.rmse, s.max, 100.0 * static_cast<double>(ok) / static_cast<double>(n),
                100.0 * static_cast<double>(s.within) / static_cast<double>(n), pl::median(r->register_ms),
                pl::percentile(r->register_ms, 99),
                ms_or_dash(r->target_ms).c_str(), ms_or_dash(r->index_ms).c_str());
  }
  std::printf("  coverage: share of scans the method itself accepted (ours: fused, or from a given start accepted; PCL: "
              "converged before the iteration limit); <0.5 m: share within 0.5 m of the ground truth\n");
  if (!from_truth)
    std::printf("  target / index: PCL's per-scan map gathering and k-d tree (NDT: cell) build, medians, not in reg; "
                "ours keeps its ROI map up to date incrementally: median %.2f ms a scan\n",
                pl::median(ours.map_ms));
  std::printf("\n");

  std::printf("settings:\n");
  for (const Run* r : runs) std::printf("  %-38s %s\n", r->name.c_str(), r->settings.c_str());
  if (!per_scan.empty()) {  // each method's error at each scan, to see where they part
    std::ofstream csv(per_scan);
    csv << "frame";
    for (const Run* r : runs) csv << ",\"" << r->name << "\"";
    csv << "\n";
    for (std::size_t k = 0; k < n; ++k) {
      csv << (ds.frame_ids.empty() ? static_cast<long>(scans[k]) : ds.frame_ids[scans[k]]);
      for (const Run* r : runs) csv << "," << (r->poses[k].translation() - gt[k].translation()).norm();
      csv << "\n";
    }
    if (!csv) throw std::runtime_error("cannot write " + per_scan);
    std::printf("per-scan errors -> %s\n", per_scan.c_str());
  }
  std::printf("\nwhere they go wrong (frames are the drive's):\n");
  for (const Run* r : runs) {
    const ApeStats s = ape(r->poses, gt);
    const auto frame = [&](std::size_t k) { return ds.frame_ids.empty() ? static_cast<long>(scans[k]) : ds.frame_ids[scans[k]]; };
    std::printf("  %-38s worst %.3f m at frame %ld", r->name.c_str(), s.max, frame(s.worst));
    if (s.first_off >= 0) std::printf("; first more than 1 m off at frame %ld", frame(static_cast<std::size_t>(s.first_off)));
    if (r == &ours) std::printf("; health: %d degraded, %d lost", ours.degraded, ours.lost);
    std::printf("\n");
  }

  const ApeStats f = ape(floor.poses, gt);
  if (from_truth && ours_only) {
    std::printf("\nfrom the truth and 0.2 m from it: ours %.3f / %.3f m mean\n", f.mean, ape(floor_off.poses, gt).mean);
    return 0;
  }
  if (from_truth) {
    const ApeStats fo = ape(floor_off.poses, gt), ig = ape(icp_gt.poses, gt), io = ape(icp_off.poses, gt);
    const ApeStats gg = ape(gicp_gt.poses, gt), go = ape(gicp_off.poses, gt);
    std::printf("\nfrom the truth and 0.2 m from it: ours %.3f / %.3f m, PCL ICP %.3f / %.3f m, PCL GICP %.3f / %.3f m mean\n",
                f.mean, fo.mean, ig.mean, io.mean, gg.mean, go.mean);
    return 0;
  }
  const ApeStats ours_ape = ape(ours.poses, gt);
  const double ours_reg = pl::median(ours.register_ms);
  const double ours_scan = per_scan_median(ours);
  std::printf("\nagainst ours (%.3f m mean APE, registration %.2f ms median a scan, %.2f ms with its map upkeep):\n",
              ours_ape.mean, ours_reg, ours_scan);
  for (const Run* r : ours_only ? std::vector<const Run*>{} : std::vector<const Run*>{&icp_pp, &icp_pl, &ndt}) {
    const ApeStats s = ape(r->poses, gt);
    const double reg = pl::median(r->register_ms), whole = per_scan_median(*r);
    std::printf("  %s %.3f m at %.0f ms = %.0fx slower than ours (%.0fx with target and index: %.0f ms vs %.2f ms)\n",
                r->name.c_str(), s.mean, reg, reg / ours_reg, whole / ours_scan, whole, ours_scan);
  }
  std::printf("  floor: ours restarted at each scan's ground truth %.3f m mean (ours from its own estimates %.3f m)\n", f.mean,
              ours_ape.mean);
  return 0;
} catch (const std::exception& e) {
  std::fprintf(stderr, "bench_localize: %s\n", e.what());
  return 1;
}

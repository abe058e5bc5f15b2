// Loop proposals by position and by place, verified by ICP against a local map, added to the graph.
#include "pl/maps/loop_closure.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>

#include "pl/common/error.hpp"
#include "pl/common/stats.hpp"
#include "pl/common/voxel.hpp"
#include "pl/maps/map_builder.hpp"
#include "pl/registration/icp.hpp"
#include "pl/registration/normals.hpp"
#include "pl/registration/point_map.hpp"
#include "pl/registration/pose_search.hpp"

namespace pl::maps {
namespace {

using registration::compare_descriptors;
using registration::DescriptorMatch;
using registration::make_place_descriptor;
using registration::PlaceDescriptor;
using registration::ring_key_distance;

constexpr double kDeg = M_PI / 180.0;
constexpr double kFineCellM = 0.5;    // the local map's cells for ICP (pairs up to 0.5 m)
constexpr double kCoarseCellM = 2.0;  // and for the seeds of a search by place

// The keyframes within `submap_m` of path of `center`, merged in its frame at the current estimate,
// with normals.
struct LocalMap {
  Points3d points;
  std::vector<Eigen::Vector3f> normals;
};

// `begin`..`end`: the keyframes of the center's drive.
LocalMap local_map(const PoseList& estimate, const std::vector<double>& path, const std::vector<std::vector<Eigen::Vector3f>>& clouds,
                   std::size_t center, std::size_t begin, std::size_t end, const LoopClosureConfig& cfg) {
  VoxelAccumulator acc(cfg.target_voxel_m);
  const Pose to_center = estimate[center].inverse();
  for (std::size_t m = center; m-- > begin && path[center] - path[m] <= cfg.submap_m;) {
    const Pose rel = to_center * estimate[m];
    for (const Eigen::Vector3f& p : clouds[m]) acc.add(rel * p.cast<double>(), 0.0f);
  }
  for (std::size_t m = center; m < end && path[m] - path[center] <= cfg.submap_m; ++m) {
    const Pose rel = to_center * estimate[m];
    for (const Eigen::Vector3f& p : clouds[m]) acc.add(rel * p.cast<double>(), 0.0f);
  }
  std::vector<float> intensity;
  LocalMap out;
  out.points = acc.centroids(intensity);
  out.normals = registration::estimate_normals(out.points, cfg.normal_radius_m);
  return out;
}

// The local map in `cell_m` cells, anchored on that cell grid at the height of `near`.
std::unique_ptr<registration::PointMap> point_map(const LocalMap& local, double cell_m, const Eigen::Vector3d& near) {
  auto map = std::make_unique<registration::PointMap>(Eigen::Vector3d(0, 0, std::floor(near.z() / cell_m) * cell_m), cell_m);
  map->add(0, local.points, local.normals);
  return map;
}

std::vector<Eigen::Vector3f> thin(const std::vector<Eigen::Vector3f>& cloud, double voxel) {
  Points3d pts;
  pts.reserve(cloud.size());
  for (const Eigen::Vector3f& p : cloud) pts.push_back(p.cast<double>());
  std::vector<Eigen::Vector3f> out;
  for (const Eigen::Vector3d& p : voxel_downsample(pts, voxel)) out.push_back(p.cast<float>());
  return out;
}

Information6 edge_information(const registration::IcpResult& r, const LoopClosureConfig& cfg) {
  // ICP perturbs the pose on the left in the match's frame (R' = exp(w) R, t' = t + v); the graph's
  // loop residual is a perturbation on the right, in the query's frame: (R^T v, R^T w).
  Information6 a = Information6::Zero();
  a.topLeftCorner<3, 3>() = a.bottomRightCorner<3, 3>() = r.pose.linear().transpose();
  Information6 cov = a * r.covariance * a.transpose();
  cov = 0.5 * (cov + cov.transpose());
  const double st = cfg.sigma_m, sr = cfg.sigma_deg * kDeg;
  cov.diagonal() += (Eigen::Matrix<double, 6, 1>() << st * st, st * st, st * st, sr * sr, sr * sr, sr * sr).finished();
  Information6 info = cov.ldlt().solve(Information6::Identity());
  return 0.5 * (info + info.transpose());
}

}  // namespace

LoopReport close_loops(PoseGraph& graph, const std::vector<std::vector<Eigen::Vector3f>>& clouds, const LoopClosureConfig& cfg,
                       const std::function<void(std::size_t, std::size_t)>& progress) {
  const std::size_t n = graph.keyframes().size();
  if (clouds.size() != n)
    throw Error("loop closure: " + std::to_string(clouds.size()) + " keyframe clouds for " + std::to_string(n) + " keyframes");
  LoopReport rep;
  if (n == 0) return rep;

  // Path length along each drive's odometry to each keyframe, the descriptors, and the estimate.
  const std::size_t drives = graph.drives();
  std::vector<std::size_t> drive(n), begin(n), end(n);  // per keyframe: its drive and the drive's keyframes
  for (std::size_t d = 0; d < drives; ++d) {
    const std::size_t b = graph.first_keyframe(d), e = d + 1 < drives ? graph.first_keyframe(d + 1) : n;
    for (std::size_t k = b; k < e; ++k) drive[k] = d, begin[k] = b, end[k] = e;
  }
  std::vector<double> path(n, 0.0);
  for (std::size_t k = 1; k < n; ++k)
    if (drive[k] == drive[k - 1])
      path[k] = path[k - 1] + (graph.odometry_pose(k).translation() - graph.odometry_pose(k - 1).translation()).norm();
  std::vector<PlaceDescriptor> descriptors(n);
  for (std::size_t k = 0; k < n; ++k) descriptors[k] = make_place_descriptor(clouds[k], cfg.descriptor);
  PoseList estimate(n);
  auto refresh = [&] {
    for (std::size_t k = 0; k < n; ++k) estimate[k] = graph.keyframe_pose(k);
  };
  refresh();
  const PoseList before = estimate;
  std::vector<bool> tied_before(drives);  // drives whose estimate `before` places on the map
  for (std::size_t d = 0; d < drives; ++d) tied_before[d] = graph.joined(d);

  registration::IcpConfig icp;
  icp.max_pair_m = 0.5;
  icp.kernel_m = 0.2;
  icp.kernel_start_m = 1.0;
  icp.max_iterations = 40;

  struct Accepted {
    std::size_t a, b;
    Pose z;
    bool floating;  // between drives not both on the map before loops: no residual before
  };
  std::vector<Accepted> accepted;
  double next_query = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    if (progress) progress(i + 1, n);
    if (i > 0 && drive[i] != drive[i - 1]) next_query = 0.0;
    if (path[i] < next_query || graph.fixed(drive[i])) continue;  // a base map's drives are where they are
    // Eligible matches: the keyframes of earlier drives, and this drive's at least min_separation_m
    // of path behind. Between a drive tied to the map and a floating one, only a proposal by place
    // means anything (the floating drive's estimate is in its own frame); two floating drives wait.
    const bool here_joined = graph.joined(drive[i]);
    std::vector<std::size_t> eligible;
    for (std::size_t j = 0; j < begin[i] && cfg.between_drives; ++j)
      if (here_joined || graph.joined(drive[j])) eligible.push_back(j);
    if (path[i] >= cfg.min_separation_m && here_joined) {
      const auto last = std::upper_bound(path.begin() + static_cast<long>(begin[i]), path.begin() + static_cast<long>(i),
                                         path[i] - cfg.min_separation_m);
      for (std::size_t j = begin[i]; j < static_cast<std::size_t>(last - path.begin()); ++j) eligible.push_back(j);
    }
    if (eligible.empty()) continue;
    ++rep.queries;

    struct Proposal {
      std::size_t match;
      bool by_descriptor;
      double descriptor_distance;
      Pose guess;  // the query's pose in the match's frame
    };
    std::vector<Proposal> proposals;
    // By position, among keyframes whose estimate shares the query's frame.
    std::size_t nearest = n;
    double nearest_d = cfg.position_radius_m;
    for (std::size_t j : eligible) {
      if (!here_joined || !graph.joined(drive[j])) continue;
      const double d = (estimate[j].translation() - estimate[i].translation()).head<2>().norm();
      if (d <= nearest_d) nearest_d = d, nearest = j;
    }
    if (nearest < n) proposals.push_back({nearest, false, 1.0, estimate[nearest].inverse() * estimate[i]});
    // By place: tried when the position search proposes nothing or its proposal fails (the estimate
    // may have drifted so far that the nearest keyframe in it is not the one revisited).
    if (cfg.descriptor_candidates > 0) {
      std::vector<std::pair<double, std::size_t>> keyed;
      for (std::size_t j : eligible) keyed.push_back({ring_key_distance(descriptors[i], descriptors[j]), j});
      const std::size_t take = std::min<std::size_t>(keyed.size(), static_cast<std::size_t>(cfg.descriptor_candidates));
      std::partial_sort(keyed.begin(), keyed.begin() + static_cast<long>(take), keyed.end());
      DescriptorMatch best;
      std::size_t best_j = n;
      for (std::size_t c = 0; c < take; ++c) {
        const DescriptorMatch m = compare_descriptors(descriptors[i], descriptors[keyed[c].second]);
        if (m.distance < best.distance) best = m, best_j = keyed[c].second;
      }
      if (best_j < n && best.distance <= cfg.descriptor_max_distance) {
        // Same place, turned by the descriptor's heading; height from the estimate (of a drive tied
        // to the map; a floating drive's height is its own: the search's ICP finds it).
        Pose guess = estimate[best_j].inverse() * estimate[i];
        guess.translation() = Eigen::Vector3d(0, 0, graph.joined(drive[best_j]) && here_joined ? guess.translation().z() : 0.0);
        guess.linear() = Eigen::AngleAxisd(best.yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
        proposals.push_back({best_j, true, best.distance, guess});
      }
    }
    if (proposals.empty()) continue;
    const std::vector<Eigen::Vector3f> source = thin(clouds[i], cfg.source_voxel_m);  // the query, for every proposal
    for (const Proposal& p : proposals) {
      (p.by_descriptor ? rep.proposed_by_descriptor : rep.proposed_by_position)++;
      const auto t0 = std::chrono::steady_clock::now();
      LoopRecord rec;
      rec.query = i;
      rec.match = p.match;
      rec.by_descriptor = p.by_descriptor;
      rec.descriptor_distance = p.descriptor_distance;
      const LocalMap local = local_map(estimate, path, clouds, p.match, begin[p.match], end[p.match], cfg);
      const auto fine = point_map(local, kFineCellM, Eigen::Vector3d::Zero());
      registration::IcpResult r;
      bool registered = false;
      if (!p.by_descriptor) {
        r = registration::register_scan(*fine, source, p.guess, icp);
        registered = r.accepted;
        if (!registered) rec.reason = std::string("icp: ") + r.reject_reason;
      } else {
        registration::PoseSearch search;
        search.radius_m = cfg.descriptor_search_m;
        search.position_step_m = 2.0;
        search.yaw_range_deg = cfg.descriptor_search_deg;
        search.yaw_step_deg = 7.5;
        Eigen::Isometry3d found;
        const auto coarse = point_map(local, kCoarseCellM, p.guess.translation());
        if (!registration::search_pose(*coarse, *fine, source, p.guess, search, icp, found)) {
          rec.reason = "no registration found";
        } else {
          r = registration::register_scan(*fine, source, found, icp);
          registered = r.accepted;
          if (!registered) rec.reason = std::string("icp: ") + r.reject_reason;
        }
      }
      rep.verify_ms += std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
      rec.overlap = r.inlier_share;
      rec.rms_m = r.rms_m;
      if (registered) {
        const Pose correction = p.guess.inverse() * r.pose;
        rec.correction_m = correction.translation().norm();
        const Pose odometry_rel = graph.odometry_pose(p.match).inverse() * graph.odometry_pose(i);
        rec.drift_m = (odometry_rel.inverse() * r.pose).translation().norm();
        if (r.inlier_share < cfg.min_overlap)
          rec.reason = "overlap too small";
        else if (r.rms_m > cfg.max_rms_m)
          rec.reason = "residual too large";
        else if (!p.by_descriptor &&
                 (rec.correction_m > cfg.max_correction_m || rotation_angle(correction) > cfg.max_correction_deg * kDeg))
          rec.reason = "correction too large";
      }
      rec.accepted = rec.reason.empty();
      rep.loops.push_back(rec);
      if (!rec.accepted) {
        ++rep.rejected;
        ++rep.rejected_by_reason[rec.reason];
        continue;
      }
      // Trial: the edge goes in and the graph is re-solved; it stays only if the graph can take it in.
      // A loop between a floating drive and the map first moves the floating drive onto it.
      const std::vector<double> saved = graph.save();
      const double gps_before = graph.gps_cost();
      const bool joining = !graph.joined(drive[i]) || !graph.joined(drive[p.match]);
      if (!graph.joined(drive[i]))
        graph.join_drive(drive[i], estimate[p.match] * r.pose * estimate[i].inverse());
      else if (!graph.joined(drive[p.match]))
        graph.join_drive(drive[p.match], estimate[i] * r.pose.inverse() * estimate[p.match].inverse());
      if (joining) refresh();
      const std::size_t id = graph.add_loop(p.match, i, r.pose, edge_information(r, cfg));
      graph.optimize(cfg.solve_iterations);
      refresh();
      const double residual = ((estimate[p.match].inverse() * estimate[i]).inverse() * r.pose).translation().norm();
      const double gps_rise = graph.gps_cost() - gps_before;
      // (A joining loop is the floating drive's only tie: nothing in the graph can disagree with it.)
      if (!joining && (residual > cfg.max_residual_m || gps_rise > cfg.max_gps_cost_rise)) {
        graph.remove_loop(id);
        graph.restore(saved);
        refresh();
        rec.accepted = false;
        rec.reason = residual > cfg.max_residual_m ? "not absorbed by the graph" : "at odds with the GPS";
        rep.loops.back() = rec;
        ++rep.rejected;
        ++rep.rejected_by_reason[rec.reason];
        continue;
      }
      ++rep.accepted;
      accepted.push_back({p.match, i, r.pose, !tied_before[drive[i]] || !tied_before[drive[p.match]]});
      next_query = path[i] + cfg.cooldown_m;
      break;
    }
  }
  if (!accepted.empty()) {
    graph.optimize();
    refresh();
  }
  std::vector<double> res_before, res_after;
  for (const Accepted& a : accepted) {
    if (!a.floating) res_before.push_back(((before[a.a].inverse() * before[a.b]).inverse() * a.z).translation().norm());
    res_after.push_back(((estimate[a.a].inverse() * estimate[a.b]).inverse() * a.z).translation().norm());
  }
  rep.residual_before_m = res_before.empty() ? 0.0 : median(res_before);
  rep.residual_after_m = res_after.empty() ? 0.0 : median(res_after);
  return rep;
}

}  // namespace pl::maps

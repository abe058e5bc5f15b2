// Loop closures for the pose graph: when the drive comes back to a place, the relative pose between
// the keyframe now and a keyframe from the earlier visit is measured by ICP and added as an edge.
//
// Keyframes are taken in drive order, drive after drive. Each queries its own drive's keyframes at
// least min_separation_m of path behind it and every keyframe of the earlier drives, proposed two ways: by position (the nearest in the current estimate, within
// position_radius_m) and by place (the place descriptor's nearest neighbours, for when drift has
// moved the estimate too far). A proposal is verified by point-to-plane ICP of the keyframe's cloud
// against a local map around the earlier keyframe (its neighbours along the drive merged, normals
// estimated): it enters the graph only with enough overlap, a small residual, a well-conditioned
// problem and (by position) a correction the estimate can explain; the graph is re-solved with it,
// and the edge stays only if the graph can take it in without leaving the GPS fixes, so later
// proposals start from the corrected estimate. A last solve runs to convergence at the end.
//
// A drive with no GPS floats in its own frame until a loop by place ties it to a drive that is tied
// to the map: the first such loop moves it onto the map (PoseGraph::join_drive).
#pragma once

#include <Eigen/Core>

#include <cstddef>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "pl/registration/place_descriptor.hpp"
#include "pl/maps/pose_graph.hpp"

namespace pl::maps {

struct LoopClosureConfig {
  // Proposals.
  bool between_drives = true;        // false: each drive's loops within itself only
  double min_separation_m = 30.0;    // path between the two keyframes, at least
  double position_radius_m = 10.0;   // by position: the nearest keyframe this close (horizontal), current estimate
  int descriptor_candidates = 5;     // by place: this many ring-key neighbours compared in full ...
  double descriptor_max_distance = 0.3;  // ... the best kept when at most this far (0 same .. 1)
  double descriptor_search_m = 6.0;  // its registration searches seeds this far round the match, and
  double descriptor_search_deg = 15.0;  // this far round the descriptor's heading
  double cooldown_m = 5.0;           // after an accepted loop, the next query this much path later
  // Verification.
  double submap_m = 10.0;            // local map: keyframes within this much path of the match
  double target_voxel_m = 0.25;      // local map resolution
  double normal_radius_m = 0.75;     // its normals
  double source_voxel_m = 0.75;      // the querying keyframe's cloud, thinned
  double min_overlap = 0.6;          // share of its points paired with the local map, at least
  double max_rms_m = 0.1;            // plane-distance RMS of the pairs, at most
  double max_correction_m = 3.0;     // by position: ICP may move the estimate's guess this far ...
  double max_correction_deg = 10.0;  // ... and turn it this much
  // The edge: the registration's covariance plus these standard deviations. Tight on purpose: the
  // chain's covariance is a random walk, but its drift is systematic (many times larger round a long
  // loop), and a loop measured between two views of one place must outweigh it.
  double sigma_m = 0.005;
  double sigma_deg = 0.005;
  // Trial: the graph is re-solved (this many iterations) with each new edge, which is taken out again
  // (and the estimate put back) when the graph cannot absorb it (its translation residual after the
  // solve above max_residual_m: at odds with earlier loops, or too much to close in one go) or when it
  // pulls the graph away from the GPS fixes (their robust cost rises by more than max_gps_cost_rise,
  // in squared standard deviations). A loop edge is tight, so without GPS or earlier loops nothing
  // can veto it: the registration checks above carry the weight then.
  int solve_iterations = 20;
  double max_residual_m = 0.3;
  double max_gps_cost_rise = 10.0;
  registration::PlaceDescriptorConfig descriptor;
};

struct LoopRecord {
  std::size_t query = 0, match = 0;  // keyframes: the later one and the earlier one
  bool by_descriptor = false;        // proposed by place, not by position
  bool accepted = false;
  std::string reason;                // why rejected ("" when accepted)
  double descriptor_distance = 1.0;
  double overlap = 0, rms_m = 0;     // of the registration
  double correction_m = 0;           // ICP result against the estimate's guess
  double drift_m = 0;                // ICP result against the odometry alone: drift accumulated round the loop
};

struct LoopReport {
  std::size_t queries = 0;
  std::size_t proposed_by_position = 0, proposed_by_descriptor = 0;
  std::size_t accepted = 0, rejected = 0;
  std::map<std::string, std::size_t> rejected_by_reason;
  std::vector<LoopRecord> loops;  // every verified proposal, in order
  double verify_ms = 0;           // registrations and local maps
  double residual_before_m = 0;   // median translation residual of the accepted loop edges against the
  double residual_after_m = 0;    // graph before loops were added (odometry + GPS; loops of drives that floated
                                  // then left out) and after the last solve
};

// Finds and adds loop edges to `graph`, re-solving it on each one. `clouds` holds one cloud per
// keyframe of the graph (sensor frame; thinned to ~0.2-0.3 m). `progress(done, total)` may be null.
// Throws pl::Error when the clouds do not match the keyframes.
LoopReport close_loops(PoseGraph& graph, const std::vector<std::vector<Eigen::Vector3f>>& clouds, const LoopClosureConfig& cfg,
                       const std::function<void(std::size_t, std::size_t)>& progress = {});

}  // namespace pl::maps

// LiDAR odometry in the manner of LOAM: sharp (edge) and flat (plane) points picked along each ring
// by their local curvature, registered scan-to-map against the features of the recent keyframes
// (point-to-line and point-to-plane, Gauss-Newton with a robust weight), one pose per scan.
//
// The local map is two voxel hashes (edges, planes) of points in the map frame, thinned to one point
// per leaf and pruned by distance as the vehicle moves: it is updated by the keyframes, never rebuilt.
// Map points are float offsets from the first pose (~0.1 mm within a few kilometres).
// The correspondence search is split over LoamConfig::threads; the rest runs on the calling thread.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

#include <cstdint>
#include <memory>
#include <vector>

#include "pl/common/pose.hpp"
#include "pl/common/scan.hpp"

namespace pl::maps {

struct LoamConfig {
  // Points kept.
  double min_range_m = 2.0;    // returns from the vehicle itself
  double max_range_m = 100.0;  // far returns are sparse and noisy
  // Features along each ring (points in scan order).
  int curvature_neighbours = 5;     // curvature from this many points on each side
  int sectors = 6;                  // per ring, each with its own caps, so features spread round the scan
  double edge_curvature = 0.5;      // |sum of (neighbour - point)|^2 (m^2) above which a point may be an edge
  double plane_curvature = 0.1;     // ... below which it may be a plane point
  int max_edges_per_sector = 20;    // sharpest first, their ring neighbours suppressed
  int max_planes_per_sector = 80;   // flattest first
  double occlusion_ratio = 0.1;     // a range jump between ring neighbours of more than this share of the
                                    // nearer range: the farther side is the edge of a shadow, not an edge
  double grazing_ratio = 0.02;      // gaps to both ring neighbours longer than this share of the range:
                                    // a surface seen nearly edge-on, unreliable
  double edge_voxel_m = 0.2;        // one edge point per leaf of this size (scan and local map)
  double plane_voxel_m = 0.4;       // one plane point per leaf of this size (scan and local map)
  // Local map.
  double map_cell_m = 1.0;          // hash cell; the neighbour search looks at the 8 cells nearest the query
  int map_points_per_cell = 24;     // cap per cell and feature kind (at most 255)
  double map_radius_m = 100.0;      // cells farther than this (horizontally) from the sensor are dropped
  double keyframe_m = 0.5;          // a scan joins the map after the sensor moved this far ...
  double keyframe_deg = 5.0;        // ... or turned this much since the last keyframe
  // Scan-to-map registration.
  int max_rematches = 4;            // nearest-neighbour searches (each refits the lines and planes) ...
  double rematch_m = 0.005;         // ... the next one only when the steps on the last one moved the
  double rematch_rad = 0.001;       // sensor more than this or turned it more than this
  int iterations_per_match = 3;     // Gauss-Newton steps on each set of lines and planes
  double max_neighbour_m = 1.0;     // the 5 map neighbours must all lie this close
  double plane_fit_m = 0.2;         // a plane is kept when its 5 points lie this close to it
  double line_ratio = 3.0;          // a line is kept when its points spread this many times more along it
  double kernel_m = 0.2;            // Cauchy weight scale on the point-to-line / point-to-plane distance
  double max_residual_m = 1.0;      // pairs farther from their line or plane are dropped
  double converged_m = 1e-3;        // Gauss-Newton on one set of pairs stops once a step moves the sensor
  double converged_rad = 1e-4;      // less than this and turns it less than this
  int min_correspondences = 300;    // fewer matched features: the view is blocked or the scan is empty; it is
                                    // not registered (prediction kept, flagged degenerate, not a keyframe)
  double max_correction_m = 1.0;    // a solution farther than this from the constant-velocity prediction ...
  double max_correction_deg = 5.0;  // ... or turned more than this from it is rejected the same way
                                    // (from the third scan on; 0 m: no check)
  double degenerate_ratio = 1e-3;   // directions of the normal matrix (rotations weighed as 10 m lever arms)
                                    // weaker than this share of the strongest are not updated, and flag
                                    // the frame degenerate
  // Motion within a scan.
  bool deskew = false;              // correct each feature for the motion during the sweep (the predicted
                                    // velocity); for real recordings and pl-sim's swept scans
  double redeskew_m = 0.01;         // the sweep the registration found differs from the predicted one by
  double redeskew_deg = 0.05;       // more than this: deskewed again with it and solved once more
  double scan_period_s = 0.1;       // sweep time; the sensor spins counter-clockwise seen from above and
                                    // the scan's time is when it faces straight ahead (KITTI's HDL-64E)
  // Work.
  int threads = 2;                  // the correspondence search split over this many threads; the
                                    // result does not depend on it
};

// The features of one scan, in the sensor frame.
struct LoamFeatures {
  std::vector<Eigen::Vector3f> edges, planes;
  std::vector<float> edge_time, plane_time;  // time offset of each from the scan's time, in sweeps [-0.5, 0.5]
};

// Per ring, in scan order: curvature, occlusion and grazing rejection, capped picks per sector,
// then one point per leaf. `rings` holds the ring of every point. Throws pl::Error when the sizes differ.
LoamFeatures extract_loam_features(const Scan& scan, const std::vector<std::uint16_t>& rings, const LoamConfig& cfg = {});

struct LoamFrame {
  Pose pose = Pose::Identity();  // sensor pose in the odometry frame
  double ms = 0;                 // time spent in add(), extracting the features included
  int edges = 0, planes = 0;     // scan features used (matched at the last search)
  int iterations = 0;            // Gauss-Newton steps
  bool degenerate = false;       // too few matches, or a direction the scan does not constrain
  bool keyframe = false;         // the scan's features joined the local map
  // J^T W J at the solution for a perturbation in the sensor frame, pose * exp(d), d = (translation,
  // rotation) (unit measurement variance: scale by 1/sigma^2 for a covariance). Zero when the scan was
  // not registered (the first scan, or the prediction kept).
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  EIGEN_MAKE_ALIGNED_OPERATOR_NEW
};

class LoamOdometry {
 public:
  explicit LoamOdometry(const LoamConfig& cfg = {});
  ~LoamOdometry();
  LoamOdometry(const LoamOdometry&) = delete;
  LoamOdometry& operator=(const LoamOdometry&) = delete;

  // One scan (sensor frame) with its ring per point, taken at t (seconds). The first scan defines the
  // origin unless start() was called. Constant-velocity prediction, then scan-to-map. An empty or
  // featureless scan keeps the prediction and comes back flagged degenerate.
  LoamFrame add(const Scan& scan, const std::vector<std::uint16_t>& rings, double t);
  // The same with the scan's features already extracted (with config()'s settings), e.g. on another
  // thread while the previous scan registers; `ms` then leaves the extraction out.
  LoamFrame add(LoamFeatures features, double t);
  // The pose of the next (first) scan; call before the first add().
  void start(const Pose& first_pose);

  std::size_t map_edges() const;
  std::size_t map_planes() const;
  const LoamConfig& config() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace pl::maps

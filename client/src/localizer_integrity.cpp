// The localizer's search round a prediction and its integrity checks on a registration: perturbed
// seeds, alternatives, the basin's flatness, the absolute and relative checks and the protection
// level (Localizer::search, Localizer::check_integrity; the rest of the class is in localizer.cpp).
#include <Eigen/Eigenvalues>

#include <algorithm>
#include <cmath>
#include <limits>

#include "localizer_geometry.hpp"
#include "pl/client/localizer.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/stats.hpp"
#include "pl/registration/motion.hpp"

namespace pl::client {
namespace {

// The registration's horizontal position sigma: the largest of its covariance proxy's xy block,
// inflated as if only `independent` of the pairs were independent (neighbouring residuals are not).
double registration_sigma(const registration::IcpResult& r, double independent) {
  const Eigen::Matrix2d xy = r.covariance.topLeftCorner<2, 2>();
  const double top = Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(xy, Eigen::EigenvaluesOnly).eigenvalues()(1);
  return std::sqrt(std::max(0.0, top)) * std::sqrt(std::max(1.0, static_cast<double>(r.pairs) / independent));
}

// Poses distinctly different: farther apart than distinct_m, or turned more than distinct_deg.
bool distinct(const Eigen::Isometry3d& a, const Eigen::Isometry3d& b, const IntegrityConfig& c) {
  return horizontal_distance(a, b) > c.distinct_m || turn_between(a, b) > c.distinct_deg * kDeg;
}

// The horizontal direction the registration holds least (x when its covariance says nothing).
Eigen::Vector2d weakest_direction(const registration::IcpResult& r) {
  const Eigen::Matrix2d xy = r.covariance.topLeftCorner<2, 2>();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(xy);
  Eigen::Vector2d weak = es.eigenvectors().col(1);
  if (!weak.allFinite() || weak.norm() < 0.5) weak = Eigen::Vector2d::UnitX();
  return weak;
}

}  // namespace

std::vector<registration::Candidate> Localizer::search(const std::vector<Eigen::Vector3f>& points,
                                                      const Eigen::Isometry3d& guess, const Uncertainty& u, ScanReport& r) {
  const MotionConfig& m = cfg_.motion;
  const bool jumped = relocalizing_;
  bool thinned = false;  // the region was too large for its seeds at their usual spacing
  std::vector<registration::Candidate> found;
  // The region round the prediction (not when there is none).
  if (!global_) {
    registration::PoseSearch s;
    s.position_step_m = 2.0;
    // With places to propose where else the vehicle may be, the region round the prediction stays
    // within the search caps; without, a relocalization covers its whole reach.
    const double reach = jumped && !has_places() ? m.relocalize_m : m.search_across_m;
    s.along_m = std::clamp(3.0 * u.along, s.position_step_m, jumped ? reach : m.search_along_m);
    s.across_m = std::clamp(3.0 * u.across, s.position_step_m, jumped ? reach : m.search_across_m);
    s.yaw_range_deg = std::min(180.0, 3.0 * u.yaw / kDeg);
    s.yaw_step_deg = 8.0;
    s.refine = jumped ? 24 : 8;
    // Within the seed budget: the positions of the ellipse times the headings.
    const double headings = 2.0 * std::floor(s.yaw_range_deg / s.yaw_step_deg) + 1.0;
    const double positions = M_PI * s.along_m * s.across_m / (s.position_step_m * s.position_step_m);
    if (positions * headings > m.max_seeds) {
      s.position_step_m *= std::sqrt(positions * headings / m.max_seeds);
      thinned = true;
    }
    found = registration::search_poses(coarse_->points_map(), map_->points_map(), points, guess, s, cfg_.icp);
  }
  // The places the scan looks like, any heading: within the reach of a relocalization, anywhere when
  // there is no pose, and whenever the region was too large for seeds at their spacing (after a long
  // blind stretch: drive 0005 with 25 scans cut out and the clock running on, 5 s, the seeds were
  // 5 m apart and whether one fell in the right basin was luck). Each is searched on the maps round it.
  if ((jumped || thinned) && has_places()) {
    const PlaceConfig& pc = cfg_.places;
    // The scan levelled by the prediction's roll and pitch, as the places are.
    const Eigen::Matrix3d level = registration::levelling(guess);
    // Within the gate's reach (the gate takes 3 sigma of the uncertainty, at least relocalize_m).
    const double reach = std::max(3.0 * std::min(u.along, u.across), m.relocalize_m);
    const auto proposals = places_->propose(registration::levelled_descriptor(points, guess, places_->config()),
                                            static_cast<std::size_t>(pc.proposals), guess.translation().head<2>(),
                                            global_ ? 0.0 : reach);
    registration::PoseSearch s;
    s.along_m = s.across_m = pc.search_m;
    s.position_step_m = 2.0;
    s.yaw_range_deg = pc.search_deg;
    s.yaw_step_deg = 6.0;
    s.refine = 3;
    const TileProvider& far = far_tiles_ ? far_tiles_ : tiles_;
    for (const auto& p : proposals) {
      const Eigen::Vector2d xy = p.pose.translation().head<2>();
      if ((xy - map_center_).norm() > cfg_.roi_radius_m - m.relocalize_m) load_maps(xy, far);
      Eigen::Isometry3d seed = p.pose;
      seed.linear() = seed.linear() * level.transpose();  // the scan's tilt, as predicted
      for (auto& c : registration::search_poses(coarse_->points_map(), map_->points_map(), points, seed, s, cfg_.icp))
        found.push_back(std::move(c));
    }
    r.place_proposals = static_cast<int>(proposals.size());
  }
  std::stable_sort(found.begin(), found.end(),
                   [](const registration::Candidate& a, const registration::Candidate& b) { return a.score > b.score; });
  // The maps round the best; candidates found on other maps keep their scores (share and residual
  // do not depend on which tiles are loaded beyond the scan's reach).
  if (!found.empty() && (found.front().icp.pose.translation().head<2>() - map_center_).norm() > 1.0) {
    update_map(found.front().icp.pose.translation().head<2>());
    found.front().icp = registration::register_scan(map_->points_map(), points, found.front().icp.pose, cfg_.icp);
    found.front().score = registration::registration_score(found.front().icp);
  }
  return found;
}

void Localizer::check_integrity(const std::vector<Eigen::Vector3f>& points, ScanReport& r,
                                std::vector<registration::Candidate> alternatives) const {
  const IntegrityConfig& c = cfg_.integrity;
  if (!r.icp.accepted) return;
  // Perturbed seeds round the solution: along the direction the registration holds least and across
  // it, each with a turn. (A search has its own alternatives.)
  if (r.basin != Basin::Search && c.seeds > 0) {
    const Eigen::Vector2d weak = weakest_direction(r.icp);
    const std::vector<Eigen::Vector3f> sparse = registration::subsample(points, 400);
    const registration::IcpConfig wide = registration::coarse_icp(cfg_.icp, 10);
    registration::IcpConfig refine = cfg_.icp;
    refine.max_iterations = 20;
    // The solution's own score on the coarse map: a seed ending well below it is not refined.
    const double own = registration::registration_score(registration::register_scan(coarse_->points_map(), sparse, r.icp.pose, wide));
    for (int k = 0; k < c.seeds; ++k) {
      const double sign = k % 2 == 0 ? 1.0 : -1.0;
      const int kind = (k / 2) % 3;  // 0, 1: along the weak direction, near and far; 2: a turn
      Eigen::Isometry3d seed = r.icp.pose;
      if (kind < 2) seed.translation().head<2>() += sign * (kind == 0 ? 1.0 : 1.7) * c.seed_offset_m * weak;
      else seed.linear() = rotation_from_vector(Eigen::Vector3d(0, 0, sign * c.seed_yaw_deg * kDeg)) * seed.linear();
      const registration::IcpResult coarse = registration::register_scan(coarse_->points_map(), sparse, seed, wide);
      if (!distinct(coarse.pose, r.icp.pose, c)) continue;  // back in the solution's basin
      if (registration::registration_score(coarse) < c.ambiguity_ratio * own) continue;
      registration::Candidate alt;
      alt.icp = registration::register_scan(map_->points_map(), points, coarse.pose, refine);
      if (!alt.icp.accepted || !distinct(alt.icp.pose, r.icp.pose, c)) continue;
      alt.score = registration::registration_score(alt.icp);
      alternatives.push_back(alt);
    }
  }
  // The best distinct alternative: better by the ratio, it replaces the solution; about as good, the
  // scan is ambiguous.
  double best = registration::registration_score(r.icp);
  const registration::Candidate* top = nullptr;
  for (const auto& a : alternatives)
    if (distinct(a.icp.pose, r.icp.pose, c) && (!top || a.score > top->score)) top = &a;
  if (top && top->score * c.ambiguity_ratio > best) {
    r.alternative_m = horizontal_distance(top->icp.pose, r.icp.pose);
    r.icp = top->icp;
    r.resolved = true;
    best = top->score;
  } else if (top) {
    r.alternative_m = horizontal_distance(top->icp.pose, r.icp.pose);
    r.alternative = top->icp.pose;
    r.ambiguous = top->score >= c.ambiguity_ratio * best;
  }
  r.registration_sigma_m = registration_sigma(r.icp, c.independent_pairs);
  // The basin's flatness along the direction held least.
  if (c.probe_m > 0 && c.probe_iterations > 0) {
    const Eigen::Vector2d weak = weakest_direction(r.icp);
    const std::vector<Eigen::Vector3f> sparse = registration::subsample(points, static_cast<std::size_t>(c.probe_points));
    registration::IcpConfig probe = cfg_.icp;
    probe.max_iterations = c.probe_iterations;
    probe.kernel_start_m = probe.kernel_m;  // already near: the final kernel from the start
    for (const double sign : {1.0, -1.0}) {
      Eigen::Isometry3d seed = r.icp.pose;
      seed.translation().head<2>() += sign * c.probe_m * weak;
      const registration::IcpResult end = registration::register_scan(map_->points_map(), sparse, seed, probe);
      r.basin_spread_m = std::max(r.basin_spread_m, horizontal_distance(end.pose, r.icp.pose));
    }
  }
  // Absolute and relative checks.
  const bool absolute = r.icp.inlier_share >= c.min_share && r.icp.rms_m <= c.max_rms_m;
  // The relative check holds a scan against the scans just before it, where the vehicle was a moment
  // ago. A search's result is not: the search runs because those scans no longer describe where the
  // vehicle is (a turn into another street, a jump), and holding it to them locked a lost vehicle out
  // of every correct result (pl-sim's swept town loop: 3.8 m off, coasting, after a corner). It is
  // verified by the absolute checks, the perturbed seeds, and the next scan's confirmation.
  bool relative = true;
  if (recent_share_.size() >= 3 && r.basin != Basin::Search)
    relative = r.icp.inlier_share >= median(recent_share_) - c.share_drop && r.icp.rms_m <= c.rms_rise * median(recent_rms_);
  r.plausible = absolute;
  r.consistent = relative;
  r.verified = absolute && relative && !r.ambiguous;
  // A pose found by a search is confirmed by the next scan before it is ok.
  // The scan after a verified search result confirms it when its own search lands where that result
  // predicted (as a registration from the prediction would have).
  const MotionConfig& m = cfg_.motion;
  const bool confirms = previous_verified_ && horizontal_distance(r.predicted, r.icp.pose) <= m.fine_basin_m &&
                        turn_between(r.predicted, r.icp.pose) <= m.fine_basin_deg * kDeg;
  const bool searched = r.basin == Basin::Search && !confirms;
  r.integrity = r.verified && !r.resolved && !searched;
  // Within a few scans of an ambiguous one, one scan whose seeds find no alternative does not end the
  // ambiguity: on drive 0005 (motion compensated) a scan between ambiguous ones was ok 0.44 m off
  // under a 0.38 m bound. Only the health and the bound change; the fusion takes the scan as before.
  r.after_ambiguity = !r.ambiguous && ambiguity_hold_left_ > 0;
  if (!absolute) r.note = r.icp.inlier_share < c.min_share ? "too few scan points on a map surface" : "residual too large";
  else if (!relative) r.note = "the fit is worse than the recent scans'";
  else if (r.ambiguous) r.note = "ambiguous: another pose fits about as well";
  else if (r.resolved) r.note = "left a wrong minimum";
  else if (searched) r.note = "found by a search: to be confirmed by the next scan";
  else if (r.after_ambiguity) r.note = "just after an ambiguous scan";
  // The protection level. Unverified for another reason than ambiguity, the error is known only to be
  // within the reach of the search that would find the vehicle again.
  r.protection_m = c.map_error_m + c.sigmas * r.registration_sigma_m + r.basin_spread_m +
                   (r.ambiguous ? r.alternative_m : r.after_ambiguity ? held_alternative_m_ : 0.0);
  if (!absolute || !relative) r.protection_m = c.map_error_m + cfg_.motion.relocalize_m;
}

}  // namespace pl::client

#include "pl/eval/map_accuracy.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include <Eigen/Eigenvalues>

#include "pl/common/error.hpp"
#include "pl/common/geo.hpp"
#include "pl/common/progress.hpp"
#include "pl/common/stats.hpp"
#include "pl/eval/nearest.hpp"

namespace pl::eval {

namespace {

std::string origin_text(const GeoPoint& g) {
  char buf[128];
  std::snprintf(buf, sizeof buf, "lat %.10f, lon %.10f, alt %.4f m", g.lat_deg, g.lon_deg, g.alt_m);
  return buf;
}

}  // namespace

void check_same_origin(const Cloud& map, const std::string& map_path, const Cloud& reference,
                       const std::string& reference_path) {
  if (!map.origin || !reference.origin) return;
  const double offset = EnuFrame(*reference.origin).to_enu(*map.origin).norm();
  if (offset <= 1e-3) return;
  char metres[64];
  std::snprintf(metres, sizeof metres, "%.3f m", offset);
  throw Error(map_path + " records the geodetic origin " + origin_text(*map.origin) + " but " + reference_path +
              " records " + origin_text(*reference.origin) + " (" + metres +
              " apart): their coordinates are in different frames; compare clouds of the same world frame "
              "(e.g. build the map and the reference from drives with the same origin)");
}

MapAccuracy compute_map_accuracy(const Points3d& map, const Points3d& reference, const MapAccuracyOptions& options) {
  if (map.empty()) throw Error("the map has no points; nothing to measure");
  if (reference.empty()) throw Error("the reference has no points; nothing to measure against");
  if (!(options.within > 0.0)) throw Error("--within takes a distance in metres above 0");
  if (!(options.coverage_radius > 0.0)) throw Error("--coverage-radius takes a distance in metres above 0");

  MapAccuracy r;
  r.map_points = map.size();
  r.reference_points = reference.size();
  r.within = options.within;
  r.coverage_radius = options.coverage_radius;

  const NearestIndex ref_index(reference);
  // The reference's own spacing, from an even sample of its points.
  if (reference.size() > 1) {
    const std::size_t n = std::min(options.spacing_sample == 0 ? 1 : options.spacing_sample, reference.size());
    std::vector<double> gaps;
    gaps.reserve(n);
    for (std::size_t k = 0; k < n; ++k) {
      const std::size_t i = n == 1 ? 0 : k * (reference.size() - 1) / (n - 1);
      gaps.push_back(ref_index.nearest(reference[i], i).distance);
    }
    r.reference_spacing = summarize(gaps).median;
  }

  r.surface = options.surface;
  r.distances.resize(map.size());
  {
    Progress bar("map to reference", map.size());
    const double spacing = r.reference_spacing > 0 ? r.reference_spacing : 0.1;
    std::vector<std::size_t> near;
    for (std::size_t i = 0; i < map.size(); ++i) {
      const NearestIndex::Hit hit = ref_index.nearest(map[i]);
      r.distances[i] = hit.distance;
      if (options.surface && hit.distance <= 2.0 * spacing) {
        // The plane of the reference points around the nearest one.
        near.clear();
        ref_index.radius_search(ref_index.point(hit.index), 2.5 * spacing, near);
        if (near.size() >= 5) {
          Eigen::Vector3d mean = Eigen::Vector3d::Zero();
          for (std::size_t j : near) mean += ref_index.point(j);
          mean /= static_cast<double>(near.size());
          Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
          for (std::size_t j : near) {
            const Eigen::Vector3d d = ref_index.point(j) - mean;
            cov += d * d.transpose();
          }
          Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es;
          es.computeDirect(cov);
          const Eigen::Vector3d ev = es.eigenvalues();
          if (ev(0) < 0.05 * ev(1)) {
            r.distances[i] = std::min(hit.distance, std::abs(es.eigenvectors().col(0).dot(map[i] - mean)));
            ++r.surface_points;
          }
        }
      }
      if (i % 4096 == 0) bar.update(i);
    }
    bar.finish();
  }
  r.distance = summarize(r.distances);
  std::vector<double> sorted = r.distances;  // for the shares within each threshold
  std::sort(sorted.begin(), sorted.end());
  r.p90 = percentile(r.distances, 90.0);
  r.p95 = percentile(r.distances, 95.0);
  r.p99 = percentile(r.distances, 99.0);

  std::vector<double> thresholds = {0.02, 0.05, 0.10, 0.20, options.within};
  std::sort(thresholds.begin(), thresholds.end());
  for (double d : thresholds) {
    if (!r.shares.empty() && std::fabs(r.shares.back().distance - d) < 1e-12) continue;
    ShareWithin s;
    s.distance = d;
    s.points = static_cast<std::size_t>(std::upper_bound(sorted.begin(), sorted.end(), d) - sorted.begin());
    s.share = static_cast<double>(s.points) / static_cast<double>(sorted.size());
    r.shares.push_back(s);
  }

  // Coverage: reference points with a map point nearby.
  const NearestIndex map_index(map);
  {
    Progress bar("reference coverage", reference.size());
    for (std::size_t i = 0; i < reference.size(); ++i) {
      if (map_index.any_within(reference[i], options.coverage_radius)) ++r.reference_covered;
      if (i % 4096 == 0) bar.update(i);
    }
    bar.finish();
  }
  r.reference_coverage = static_cast<double>(r.reference_covered) / static_cast<double>(reference.size());
  return r;
}

}  // namespace pl::eval

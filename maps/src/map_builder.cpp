#include "pl/maps/map_builder.hpp"

#include <Eigen/Eigenvalues>
#include <array>
#include <cmath>
#include <string>

#include "pl/common/error.hpp"
#include "pl/common/pose.hpp"
#include "pl/common/read_ahead.hpp"
#include "pl/registration/motion.hpp"

namespace pl::maps {
namespace {

// The place of a scan at `pose`: its levelled descriptor, so that a level scan taken there later
// matches it.
registration::Place place_of(const Scan& scan, const Eigen::Isometry3d& pose, const registration::PlaceDescriptorConfig& cfg) {
  registration::Place place;
  place.position = pose.translation();
  place.yaw = registration::heading_of(pose);
  place.descriptor = registration::levelled_descriptor(to_points(scan), pose, cfg);
  return place;
}

// The scan's points moved to where the sensor was at its time: the motion between the neighbouring
// poses, at constant velocity, scaled to one sweep (a drive of one scan: as it is). Each point timed
// by `times` (seconds from the scan's time, as the driver gave them) when there is one per point,
// else by its azimuth: a point just behind the sensor may read an azimuth across the sweep's seam
// from the one it was fired at and be moved by a whole sweep's motion (the town loop's map held
// such points 0.6 m off a parked truck's side, and every later drive's rays passed through them).
void deskew(Scan& scan, const std::vector<float>& times, const Trajectory& poses, std::size_t i, double sweep_s) {
  const std::size_t a = i > 0 ? i - 1 : i, b = i + 1 < poses.size() ? i + 1 : i;
  if (a == b || poses.times.size() != poses.size()) return;
  const double dt = poses.times[b] - poses.times[a];
  if (!(dt > 0)) return;
  compensate_sweep(scan, times, scale_motion(poses.poses[a].inverse() * poses.poses[b], sweep_s / dt), sweep_s);
}

}  // namespace

void compensate_sweep(Scan& scan, const std::vector<float>& times, const Pose& sweep, double sweep_s) {
  std::vector<Eigen::Vector3f> points = to_points(scan);
  std::vector<float> shares;
  if (times.size() == scan.size())
    for (float t : times) shares.push_back(static_cast<float>(t / sweep_s));
  registration::compensate_motion(points, sweep, shares);
  for (std::size_t k = 0; k < scan.size(); ++k) scan[k].x = points[k].x(), scan[k].y = points[k].y(), scan[k].z = points[k].z();
}

VoxelAccumulator::VoxelAccumulator(double voxel) : inv_(1.0 / voxel) {
  if (!(voxel > 0.0)) throw Error("voxel size must be a positive number of metres");
}


VoxelAccumulator::Sum& VoxelAccumulator::accumulate(const Eigen::Vector3d& p, float intensity) {
  // +-2^20 voxels (+-210 km at 0.2 m) round the map's origin.
  const VoxelIndex v = voxel_index(p, inv_);
  if (!registration::packs(v[0], v[1], v[2]))
    throw Error("a point at (" + std::to_string(p.x()) + ", " + std::to_string(p.y()) + ", " + std::to_string(p.z()) +
                ") m lies too far from the map's origin for its voxels; give poses in a local frame (pl-map build "
                "takes GPS in a local ENU frame) or a larger voxel");
  // Neighbouring returns of a ring often share a voxel: the last one is looked up without the table.
  const std::uint64_t key = registration::pack_cell(v[0], v[1], v[2]);
  bool fresh = false;
  const std::uint32_t at = key == last_key_ ? last_at_ : *index_.insert(key, static_cast<std::uint32_t>(sums_.size()), fresh);
  last_key_ = key;
  last_at_ = at;
  if (fresh) {
    sums_.push_back({p.x(), p.y(), p.z(), intensity, 1});
    return sums_.back();
  }
  Sum& s = sums_[at];
  s.x += p.x(), s.y += p.y(), s.z += p.z(), s.i += intensity, ++s.n;
  return s;
}

void VoxelAccumulator::add(const Eigen::Vector3d& p, float intensity) { accumulate(p, intensity); }

void VoxelAccumulator::add(const Eigen::Vector3d& p, float intensity, std::uint32_t scan, unsigned drive) {
  Sum& s = accumulate(p, intensity);
  if (s.last_scan != scan) s.last_scan = scan, ++s.scans;
  s.drives |= std::uint64_t{1} << (drive & 63u);
}

std::vector<std::uint32_t> VoxelAccumulator::scans() const {
  std::vector<std::uint32_t> out(sums_.size());
  for (std::size_t i = 0; i < sums_.size(); ++i) out[i] = sums_[i].scans;
  return out;
}

std::vector<std::uint64_t> VoxelAccumulator::drives() const {
  std::vector<std::uint64_t> out(sums_.size());
  for (std::size_t i = 0; i < sums_.size(); ++i) out[i] = sums_[i].drives;
  return out;
}

Points3d VoxelAccumulator::centroids(std::vector<float>& intensity) const {
  Points3d out(sums_.size());
  intensity.resize(sums_.size());
  for (std::size_t i = 0; i < sums_.size(); ++i) {
    double k = 1.0 / sums_[i].n;
    out[i] = Eigen::Vector3d(sums_[i].x * k, sums_[i].y * k, sums_[i].z * k);
    intensity[i] = static_cast<float>(sums_[i].i * k);
  }
  return out;
}

void MapCloud::keep_only(const std::vector<bool>& keep) {
  if (keep.size() != points.size()) throw Error("MapCloud::keep_only: one flag per point expected");
  std::size_t out = 0;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!keep[i]) continue;
    points[out] = points[i];
    if (!intensity.empty()) intensity[out] = intensity[i];
    if (!seen.empty()) seen[out] = seen[i];
    if (!drives.empty()) drives[out] = drives[i];
    ++out;
  }
  points.resize(out);
  if (!intensity.empty()) intensity.resize(out);
  if (!seen.empty()) seen.resize(out);
  if (!drives.empty()) drives.resize(out);
}

namespace {

// The scans of each drive that the merge takes (cfg.first, last, every), loaded, corrected and cropped.
void visit_scans(const std::vector<PlacedDrive>& drives, const MapBuildConfig& cfg, const std::function<void(std::size_t)>& count,
                 const std::function<void(std::size_t, std::size_t, const Pose&, const Scan&)>& visit) {
  if (cfg.every == 0) throw Error("every must be at least 1");
  if (drives.size() > 64) throw Error("a map is built from at most 64 drives, not " + std::to_string(drives.size()));
  std::vector<std::pair<std::size_t, std::size_t>> jobs;  // (drive, scan)
  for (std::size_t k = 0; k < drives.size(); ++k) {
    const PlacedDrive& d = drives[k];
    if (d.poses->size() != d.dataset->size())
      throw Error("the map needs one pose per scan: " + std::to_string(d.poses->size()) + " poses for " +
                  std::to_string(d.dataset->size()) + " scans of " + d.dataset->dir);
    const std::size_t n = d.dataset->size();
    const std::size_t last = std::min(cfg.last, n == 0 ? 0 : n - 1);
    for (std::size_t i = cfg.first; i <= last && i < n; i += cfg.every) jobs.emplace_back(k, i);
  }
  if (count) count(jobs.size());
  // Each scan is read, corrected and cropped on the second core while the caller merges the one before.
  ReadAhead<Scan> scans(jobs.size(), [&](std::size_t j) {
    const auto [k, i] = jobs[j];
    const Dataset& ds = *drives[k].dataset;
    ScanPrepConfig prep = cfg.scan;
    prep.sensor_beams = ds.meta.sensor.beams;
    prep.voxel_m = 0.0;  // the accumulator voxelizes, exactly, in the world frame
    Frame frame = ds.load_frame(i, prep.beams > 0 && prep.beams < prep.sensor_beams);
    if (drives[k].deskew) deskew(frame.scan, frame.times, *drives[k].poses, i, drives[k].sweep_s);  // before points are dropped
    return prepare_scan(frame.scan, frame.rings, prep);
  });
  for (const auto& [k, i] : jobs) visit(k, i, drives[k].poses->poses[i], scans.next());
}

}  // namespace

MapCloud build_map_from_drives(const std::vector<PlacedDrive>& drives, const MapBuildConfig& cfg,
                               const std::function<void(std::size_t, std::size_t)>& progress) {
  VoxelAccumulator acc(cfg.voxel_m);
  std::vector<registration::Place> places;
  std::size_t total = 0, done = 0;
  std::uint32_t scan = 0;
  visit_scans(drives, cfg, [&](std::size_t t) { total = t; },
              [&](std::size_t drive, std::size_t, const Pose& pose, const Scan& kept) {
                ++scan;
                for (const auto& p : kept) acc.add(pose * Eigen::Vector3d(p.x, p.y, p.z), p.intensity, scan, static_cast<unsigned>(drive));
                if (cfg.place_spacing_m > 0 &&
                    (places.empty() || (places.back().position - pose.translation()).norm() >= cfg.place_spacing_m))
                  places.push_back(place_of(kept, pose, cfg.place));
                if (progress) progress(++done, total);
              });
  MapCloud out;
  out.points = acc.centroids(out.intensity);
  out.seen = acc.scans();
  out.drives = acc.drives();
  out.places = registration::PlaceIndex(cfg.place, std::move(places));
  return out;
}

void for_each_merged_scan(const std::vector<PlacedDrive>& drives, const MapBuildConfig& cfg,
                          const std::function<void(std::size_t, std::size_t, const Pose&, const Scan&)>& visit) {
  visit_scans(drives, cfg, {}, visit);
}

MapCloud build_map_from_poses(const Dataset& ds, const Trajectory& poses, const MapBuildConfig& cfg,
                              const std::function<void(std::size_t, std::size_t)>& progress) {
  return build_map_from_drives({{&ds, &poses, cfg.deskew, cfg.sweep_s}}, cfg, progress);
}

std::map<TileKey, TileCloud> cut_into_tiles(const Points3d& points, const std::vector<Eigen::Vector3f>& normals,
                                            const std::vector<float>& intensity, const TileGrid& grid) {
  if (!normals.empty() && normals.size() != points.size()) throw Error("cut_into_tiles: one normal per point expected");
  if (!intensity.empty() && intensity.size() != points.size()) throw Error("cut_into_tiles: one intensity per point expected");
  std::map<TileKey, TileCloud> tiles;
  for (std::size_t i = 0; i < points.size(); ++i) {
    TileCloud& t = tiles[grid.key_of(points[i].x(), points[i].y())];
    t.points.push_back(points[i]);
    if (!normals.empty()) t.normals.push_back(normals[i]);
    if (!intensity.empty()) t.intensity.push_back(intensity[i]);
  }
  return tiles;
}

}  // namespace pl::maps

#include "pl/client/config_fields.hpp"

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <initializer_list>
#include <limits>
#include <type_traits>

#include "member_count.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"

namespace pl::client {
namespace {

using detail::member_count;

// The members of each struct as the compiler counts them. A failure here means a member was added
// to (or removed from) the struct: add it to its table below -- or, when it is no number, bool or
// string, to what config_fields.hpp lists as left out -- and update the figure.
// tests/client/test_config_fields.cpp checks the table against the same counts, so a figure
// updated without the table fails there.
#define PL_MEMBERS(T, n) \
  static_assert(member_count<T>() == (n), #T " gained or lost a member: update its table in config_fields.cpp and the count")
PL_MEMBERS(ScanPrepConfig, 6);
PL_MEMBERS(RoiMapConfig, 2);
PL_MEMBERS(registration::IcpConfig, 11);
PL_MEMBERS(FusionConfig, 4);
PL_MEMBERS(MotionConfig, 27);
PL_MEMBERS(IntegrityConfig, 19);
PL_MEMBERS(PlaceConfig, 3);
PL_MEMBERS(LidarOdometryConfig, 9);
PL_MEMBERS(LocalizerConfig, 15);
PL_MEMBERS(registration::PoseSearch, 7);
PL_MEMBERS(TileClientConfig, 15);
PL_MEMBERS(ChangeEvidenceConfig, 15);
PL_MEMBERS(VehicleLocalizerConfig, 16);
#undef PL_MEMBERS

// Appends the settings of one struct under a path prefix.
class Table {
 public:
  Table(std::vector<ConfigField>& out, std::string prefix) : out_(out), prefix_(std::move(prefix)) {}
  template <class T>
  void add(const std::string& name, T& member, const char* help) {
    out_.push_back(ConfigField{prefix_ + name, &member, help});
  }
  Table under(const std::string& folder) const { return Table(out_, prefix_ + folder + "/"); }

 private:
  std::vector<ConfigField>& out_;
  std::string prefix_;
};

// The name is the member's own identifier, so the table cannot name one member and point at another.
#define FIELD(member, help) t.add(#member, c.member, help)

void add(Table t, ScanPrepConfig& c) {
  FIELD(beams, "beams kept of the sensor's (every k-th ring); 0 keeps all");
  FIELD(sensor_beams, "the sensor's beam count");
  FIELD(fov_deg, "horizontal field of view kept, centred ahead, degrees");
  FIELD(min_range_m, "returns nearer than this are dropped (the vehicle itself), m");
  FIELD(max_range_m, "returns farther than this are dropped, m");
  FIELD(voxel_m, "registration points: one per voxel of this edge, m; 0 keeps every point");
}

void add(Table t, RoiMapConfig& c) {
  FIELD(cell_m, "hash cell edge: pairs within half of it are found exactly, up to it approximately, m");
  FIELD(thin_m, "> 0: one point per voxel of this edge in each tile (a coarse map), m; 0 keeps all");
}

void add(Table t, registration::IcpConfig& c) {
  FIELD(max_iterations, "iterations at most");
  FIELD(max_pair_m, "delta: pairs farther apart are dropped, m");
  FIELD(kernel_m, "the Geman-McClure kernel's final scale on the point-to-plane distance, m");
  FIELD(kernel_start_m, "the kernel's first scale, halved each iteration down to kernel_m, m");
  FIELD(converged_m, "converged when a step moves the sensor less than this, m");
  FIELD(converged_rad, "... and turns it less than this, rad");
  FIELD(max_boost, "over-relaxation of steps that repeat the previous one's direction (1: off)");
  FIELD(unsettled_factor, "out of iterations with a last step this many times the convergence thresholds: rejected");
  FIELD(min_inlier_share, "below this share of scan points paired within delta: rejected");
  FIELD(min_inliers, "below this many pairs: rejected");
  FIELD(min_conditioning, "below this smallest / largest eigenvalue of the translation information: degenerate");
}

// The two per-axis arrays, one name per axis (vehicle frame).
void add(Table t, FusionConfig& c) {
  static const char* const axes[6] = {"x", "y", "z", "roll", "pitch", "yaw"};
  static const char* const odometry_help[6] = {"odometry's process noise per scan interval along the vehicle (1 sigma), m",
                                               "... across, m",
                                               "... vertical, m",
                                               "... roll, rad",
                                               "... pitch, rad",
                                               "... yaw, rad"};
  static const char* const lidar_help[6] = {"a registration's measurement noise along the vehicle (1 sigma), m",
                                            "... across, m",
                                            "... vertical, m",
                                            "... roll, rad",
                                            "... pitch, rad",
                                            "... yaw, rad"};
  static_assert(std::tuple_size_v<decltype(c.odometry_sigma)> == 6 && std::tuple_size_v<decltype(c.lidar_sigma)> == 6);
  for (int i = 0; i < 6; ++i) t.under("odometry_sigma").add(axes[i], c.odometry_sigma[i], odometry_help[i]);
  for (int i = 0; i < 6; ++i) t.under("lidar_sigma").add(axes[i], c.lidar_sigma[i], lidar_help[i]);
  FIELD(momentum_window, "scan intervals of the momentum's height, roll and pitch velocity");
  FIELD(momentum_plane_s, "the momentum's ground-plane velocity: the last scan intervals within this (at least one), s");
}

void add(Table t, MotionConfig& c) {
  FIELD(max_speed_mps, "a start with no velocity may be moving this fast, forward or back (3 sigma), m/s");
  FIELD(max_yaw_rate_dps, "... and turning this fast, deg/s");
  FIELD(sweep_speed_step_mps, "with motion compensation and no velocity yet, the grid the speed is sought on from the sweep's distortion, m/s");
  FIELD(sweep_yaw_rate_step_dps, "... and the turn rate's grid, deg/s");
  FIELD(sweep_points, "... and how many of the scan's points those grids register (0: no search)");
  FIELD(speed_sigma_mps, "momentum: the velocity measured from the last scans (1 sigma), m/s");
  FIELD(yaw_rate_sigma_dps, "... its turn rate (1 sigma), deg/s");
  FIELD(accel_sigma_mps2, "how fast the velocity changes since (1 sigma), m/s^2");
  FIELD(yaw_accel_sigma_dps2, "how fast the turn rate changes since (1 sigma), deg/s^2");
  FIELD(odometry_sigma_m, "LiDAR odometry's error per scan (1 sigma), m");
  FIELD(odometry_share, "... plus this share of the distance");
  FIELD(odometry_sigma_deg, "... and per scan in heading (1 sigma), deg");
  FIELD(odometry_gate_m,
        "from the fine basin, a LiDAR odometry increment this far (or 3 sigma + gate_floor_m) off is a slide, m");
  FIELD(fix_floor_m, "a fix is never taken as better than this (1 sigma), m");
  FIELD(fix_floor_deg, "... in heading, deg");
  FIELD(fine_basin_m, "3 sigma within this: plain ICP on the fine map, m");
  FIELD(fine_basin_deg, "... and within this, deg");
  FIELD(coarse_basin_m, "3 sigma within this: the coarse map first; beyond: a search of the region, m");
  FIELD(coarse_basin_deg, "... and within this, deg");
  FIELD(search_along_m, "a search covers at most this far along the heading, m");
  FIELD(search_across_m, "... and this far across it, m");
  FIELD(gate_floor_m, "a correction beyond 3 sigma of the prediction plus this is not fused, m");
  FIELD(gate_floor_deg, "... in heading, deg");
  FIELD(lost_m, "an unfused scan whose 3-sigma uncertainty is beyond this is lost, m");
  FIELD(relocalize_m,
        "after a scan that fits neither map nor recent scans, the next ones search this far round the last pose, m");
  FIELD(relocalize_deg, "... every heading within this, deg");
  FIELD(max_seeds, "a search's seeds at most (its position step grows to fit)");
}

void add(Table t, IntegrityConfig& c) {
  FIELD(min_share, "share of the scan's points on a map surface below which the result is not fused");
  FIELD(max_rms_m, "residual RMS above which the result is not fused, m");
  FIELD(share_drop, "inconsistent when the share falls by more than this below the recent verified scans'");
  FIELD(rms_rise, "... or the residual rises this many times");
  FIELD(reference_scans, "the recent verified scans the relative checks compare with");
  FIELD(seeds, "re-registrations from perturbed seeds looking for a distinct alternative pose");
  FIELD(seed_offset_m, "their offset along the direction held least (+-1 and +-1.7 times this), m");
  FIELD(seed_yaw_deg, "... and in heading, deg");
  FIELD(distinct_m, "an alternative farther than this from the solution is distinct, m");
  FIELD(distinct_deg, "... or turned more than this, deg");
  FIELD(ambiguity_ratio, "a distinct alternative scoring at least this share of the solution's makes the scan ambiguous");
  FIELD(ambiguity_hold, "scans after an ambiguous one that are not ok even when their seeds find no alternative");
  FIELD(probe_m, "the minimum's flatness: fine registrations started this far either way along the direction held least, m");
  FIELD(probe_points, "... with this many of the scan's points");
  FIELD(probe_iterations, "... and this many iterations");
  FIELD(map_error_m, "the protection level's allowance for the map's own error, m");
  FIELD(sigmas, "the protection level's multiple of the registration's position sigma");
  FIELD(independent_pairs, "the residuals are taken as if only this many pairs were independent (inflates the sigma)");
  FIELD(alert_limit_m, "a scan whose protection level exceeds this is not ok (degraded), m");
}

void add(Table t, PlaceConfig& c) {
  FIELD(proposals, "the map's places searched round per scan when lost or starting without a pose");
  FIELD(search_m, "this far round each place, m");
  FIELD(search_deg, "and this far round the heading its descriptor gives, deg");
}

void add(Table t, LidarOdometryConfig& c) {
  FIELD(scans, "scans in the LiDAR odometry's local map");
  FIELD(cell_m, "the local map's hash cell, m");
  FIELD(normal_radius_m, "a scan's normals from its own points within this, m");
  FIELD(min_inlier_share, "a scan pairing fewer of its points with the local map gives no increment");
  FIELD(planar, "take only the increment in the ground plane (along, across, yaw)");
  FIELD(seed_yaw_deg, "a wide track seeds the heading every this many degrees within 3 sigma of the motion's yaw, deg");
  FIELD(seed_range_deg, "... and at least within this, deg");
  FIELD(max_yaw_deg, "... and at most within this, deg");
  add(t.under("icp"), c.icp);
}

void add(Table t, LocalizerConfig& c) {
  add(t.under("scan"), c.scan);
  FIELD(roi_radius_m, "map tiles kept round the prediction, m");
  add(t.under("map"), c.map);
  add(t.under("coarse_map"), c.coarse_map);
  add(t.under("icp"), c.icp);
  add(t.under("fusion"), c.fusion);
  add(t.under("motion"), c.motion);
  add(t.under("integrity"), c.integrity);
  add(t.under("places"), c.places);
  FIELD(compensate_motion, "move each scan's points to where the sensor was at the scan's time (deskew)");
  FIELD(sweep_s, "the sweep the motion compensation times the points over, s");
  FIELD(lidar_odometry, "measure the motion with LiDAR odometry where no external odometry covers it");
  add(t.under("odometry"), c.odometry);
  FIELD(lost_after, "consecutive unfused scans before lost");
  FIELD(outdated_share, "share of scan points without a map pair that suggests an outdated map");
}

void add(Table t, registration::PoseSearch& c) {
  FIELD(radius_m, "positions searched within this of the guess (when along_m and across_m are not set), m");
  FIELD(position_step_m, "... every this far, m");
  FIELD(along_m, "both > 0: an ellipse this far along the guess's heading instead of the disc, m");
  FIELD(across_m, "... and this far across it, m");
  FIELD(yaw_range_deg, "headings within +- this of the guess's, deg");
  FIELD(yaw_step_deg, "... every this many degrees, deg");
  FIELD(refine, "the best seeds refined on the fine map");
}

void add(Table t, TileClientConfig& c) {
  FIELD(server, "pl-server's address, https://HOST[:PORT] (http:// to this machine, or with insecure_http)");
  FIELD(map, "the map's name");
  // version (std::optional<long long>) is left out: see config_fields.hpp.
  FIELD(cache_path, "the tile client's SQLite disk cache; empty: none");
  FIELD(memory_mb, "bound on the decoded tiles in memory, MiB");
  FIELD(radius_m, "tiles kept within this of the focus and of the look-ahead point, m");
  FIELD(timeout_s, "per request, s");
  FIELD(retry_min_s, "backoff while the server is down or erring: from this, s");
  FIELD(retry_max_s, "... doubling up to this, s");
  FIELD(token, "bearer token when the server requires one for reads");
  FIELD(ca_file, "https: PEM file of the CA the server's certificate must chain to; empty: the system's CAs");
  FIELD(insecure_http, "allow plain http:// to another machine (the map and the token cross the network in clear)");
  FIELD(fleet_keys, "PEM file of the fleet's Ed25519 public key(s): only versions signed with one are used; empty: no check");
  FIELD(timestamp_keys, "PEM file of the map service's timestamp public key(s) (needs fleet_keys): start only on a version a fresh signed "
                        "statement names current, or the newest verified; empty: the map answer's current version");
  FIELD(follow_s, "ask the server this often which map version is current, and move to a newer one mid-drive at a safe moment "
                  "(0: stay on the version of the start), s");
}

void add(Table t, ChangeEvidenceConfig& c) {
  FIELD(enabled, "keep change evidence from the ok scans for a change report to the map service");
  FIELD(delta_m, "a return with no map point this near is new, m");
  FIELD(voxel_m, "the evidence grid; a scan counts once per voxel, m");
  FIELD(min_range_m, "returns nearer than this give no evidence, m");
  FIELD(max_range_m, "returns farther than this give no evidence, m");
  FIELD(ray_step_m, "a ray's free space is probed this often, m");
  FIELD(ray_margin_m, "... up to this short of its own return, m");
  FIELD(pass_radius_m, "a probe this near a map point asks whether the ray passed through it, m");
  FIELD(cross_radius_m, "... whether it crossed the point's tangent plane this near the point, m");
  FIELD(min_incidence, "... at |cos| of the ray and the point's normal of at least this (0-1)");
  FIELD(min_travel_m, "evidence from an ok scan once the sensor moved this far since the last one that gave some, m");
  FIELD(corridor_m, "what was added within this of the sensor's own path is no evidence (the vehicle drove there), m");
  FIELD(max_cells_per_tile, "a report's bound: voxels per tile, those with most evidence kept");
  FIELD(sample_m, "the added structure is sampled on this grid for the map update (the map's voxel), m");
  FIELD(max_points_per_tile, "a report's bound: sample points per tile, those most scans saw kept");
}

void add(Table t, VehicleLocalizerConfig& c) {
  add(t.under("localizer"), c.localizer);
  add(t.under("tiles"), c.tiles);
  FIELD(store_path, "a local map store file instead of a server (tiles/map names the map)");
  FIELD(ready_timeout_s, "the constructor waits this long for the map's version and tile size, s");
  FIELD(start_wait_s, "a start waits this long for the tiles round the start pose, s");
  FIELD(lookahead_s, "tiles are also kept round where the vehicle will be this far ahead, s");
  // on_wait (a callback), base_from_lidar, base_from_antenna (Eigen) are left out: see config_fields.hpp.
  FIELD(wheel_base_m, "the wheel base, for wheel travel and ticks, m");
  FIELD(metres_per_tick, "wheel travel per encoder tick, m");
  FIELD(max_odometry_samples, "the odometry buffer's bound, samples");
  FIELD(start_from_gps, "start at the first scan that has a GPS fix within 0.5 s");
  add(t.under("search"), c.search);
  add(t.under("gps_search"), c.gps_search);
  add(t.under("changes"), c.changes);
}

#undef FIELD

std::string last_part(const std::string& name) {
  const auto slash = name.rfind('/');
  return slash == std::string::npos ? name : name.substr(slash + 1);
}

std::size_t edit_distance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diagonal = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

// How far `wanted` is from `name`: a typo in the path, or the right member in the wrong (or no)
// folder ("kernel_m" is one step from every ".../kernel_m"), or a member's name cut short
// ("max_speed" for max_speed_mps).
std::size_t name_distance(const std::string& wanted, const std::string& name) {
  const std::string w = last_part(wanted), n = last_part(name);
  const std::size_t member = w.size() < 3                     ? edit_distance(w, n)
                             : n.rfind(w, 0) == 0             ? 0  // the member itself, or its start
                             : n.find(w) != std::string::npos ? 1
                                                              : edit_distance(w, n);
  return std::min(edit_distance(wanted, name), member + 1);
}

[[noreturn]] void unknown_name(const std::vector<ConfigField>& fields, const std::string& name) {
  // The members left out on purpose (config_fields.hpp) say so, and where they are set instead.
  if (name == "tiles/version")
    throw Error(
        "tiles/version is not a setting: without a value the tile client takes the map's current version; pin one "
        "in TileClientConfig::version (pl-localize --map-version)");
  if (name == "base_from_lidar" || name == "base_from_antenna")
    throw Error(name +
                " is not a setting: extrinsics are set in VehicleLocalizerConfig from the vehicle's frames "
                "(a ROS node's TF, a drive's meta.json)");
  std::size_t best = std::numeric_limits<std::size_t>::max();
  std::vector<std::string> closest;
  for (const auto& f : fields) {
    const std::size_t d = name_distance(name, f.name);
    if (d < best) {
      closest.clear();
      best = d;
    }
    if (d == best) closest.push_back(f.name);
  }
  const std::size_t reach = std::max<std::size_t>(2, last_part(name).size() / 3);
  std::string what = "no localizer setting is named \"" + name + "\"";
  if (best > reach || closest.size() > 4)
    throw Error(what + ": names are paths of the config's members, such as localizer/icp/kernel_m or tiles/memory_mb");
  what += " (did you mean ";
  for (std::size_t i = 0; i < closest.size(); ++i) what += (i == 0 ? "" : i + 1 == closest.size() ? " or " : ", ") + closest[i];
  throw Error(what + "?)");
}

std::string lower(std::string s) {
  for (char& ch : s) ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
  return s;
}

template <class Int>
void parse_whole(const ConfigField& field, const std::string& text, Int& out) {
  using Wide = std::conditional_t<std::is_signed_v<Int>, long long, unsigned long long>;
  Wide v = 0;
  const auto [end, ec] = std::from_chars(text.data(), text.data() + text.size(), v);
  const bool digits = !text.empty() && end == text.data() + text.size();  // no fraction, exponent or sign where none may be
  bool fits = ec == std::errc() && v <= std::numeric_limits<Int>::max();
  if constexpr (std::is_signed_v<Int>) fits = fits && v >= std::numeric_limits<Int>::lowest();
  if (digits && fits) {
    out = static_cast<Int>(v);
    return;
  }
  std::string what = field.name + " takes " + config_field_type(field);
  if (digits)  // a whole number beyond the member's type
    what = field.name + " takes a whole number from " + std::to_string(std::numeric_limits<Int>::lowest()) + " to " +
           std::to_string(std::numeric_limits<Int>::max());
  throw Error(what + ", got \"" + text + "\"");
}

}  // namespace

std::vector<ConfigField> config_fields(LocalizerConfig& cfg) {
  std::vector<ConfigField> fields;
  fields.reserve(140);
  add(Table(fields, "localizer/"), cfg);
  return fields;
}

namespace {

// The ranges of the localizer's settings, by the setting's own name (the last part of its path: a
// name means the same in every struct it appears in). Every number is finite and >= 0; these are
// the stricter ones.
bool named(const std::string& leaf, std::initializer_list<const char*> names) {
  return std::any_of(names.begin(), names.end(), [&](const char* n) { return leaf == n; });
}

// What `leaf` = `v` breaks, or nothing.
std::string out_of_range(const std::string& path, const std::string& leaf, double v) {
  if (!std::isfinite(v)) return "must be a finite number";
  if (v < 0) return "must be >= 0";
  const bool axis = path.find("/odometry_sigma/") != std::string::npos || path.find("/lidar_sigma/") != std::string::npos;
  // Scales, divisors, extents and counts that nothing works without.
  if ((axis || named(leaf, {"kernel_m", "kernel_start_m", "max_pair_m", "cell_m", "converged_m", "converged_rad", "sigmas",
                            "independent_pairs", "alert_limit_m", "roi_radius_m", "max_range_m", "fov_deg", "normal_radius_m",
                            "sweep_s", "max_iterations", "momentum_window", "momentum_plane_s", "reference_scans", "scans",
                            "probe_iterations", "lost_after", "speed_sigma_mps", "yaw_rate_sigma_dps", "odometry_sigma_m",
                            "odometry_sigma_deg", "fix_floor_m", "fix_floor_deg", "sweep_speed_step_mps",
                            "sweep_yaw_rate_step_dps"})) &&
      !(v > 0))
    return "must be > 0";
  if (named(leaf, {"min_share", "min_inlier_share", "share_drop", "outdated_share", "odometry_share"}) && v > 1)
    return "is a share: from 0 to 1";
  if (leaf == "ambiguity_ratio" && !(v > 0 && v <= 1)) return "is a share: > 0 and at most 1";
  if (named(leaf, {"max_boost", "unsettled_factor", "rms_rise"}) && v < 1) return "is a factor: at least 1";
  if (leaf == "fov_deg" && v > 360) return "is at most 360";
  return {};
}

}  // namespace

std::string config_field_range_problem(const ConfigField& f) {
  if (f.name.rfind("localizer/", 0) != 0) return {};
  double v = 0;
  if (auto* d = std::get_if<double*>(&f.value))
    v = **d;
  else if (auto* i = std::get_if<int*>(&f.value))
    v = **i;
  else if (auto* n = std::get_if<std::size_t*>(&f.value))
    v = static_cast<double>(**n);
  else
    return {};
  const std::string why = out_of_range(f.name, f.name.substr(f.name.rfind('/') + 1), v);
  if (why.empty()) return {};
  return f.name + " " + why + ", got " + config_field_text(f) + " (" + f.help + ")";
}

void check_localizer_config(const LocalizerConfig& cfg) {
  LocalizerConfig copy = cfg;  // the table points into a config it may write; this one is only read
  for (const ConfigField& f : config_fields(copy)) {
    const std::string problem = config_field_range_problem(f);
    if (!problem.empty())
      throw Error("localizer setting " + problem + "; set it with pl-localize --set NAME=VALUE, the ROS node's parameter of that "
                  "name, or LocalizerConfig in code");
  }
  if (!(cfg.scan.min_range_m < cfg.scan.max_range_m))
    throw Error("localizer settings localizer/scan/min_range_m (" + std::to_string(cfg.scan.min_range_m) +
                ") must be below localizer/scan/max_range_m (" + std::to_string(cfg.scan.max_range_m) + ")");
}

std::vector<ConfigField> config_fields(VehicleLocalizerConfig& cfg) {
  std::vector<ConfigField> fields;
  fields.reserve(160);
  add(Table(fields, ""), cfg);
  return fields;
}

void set_config_field(VehicleLocalizerConfig& cfg, const std::string& name, const std::string& text) {
  const std::vector<ConfigField> fields = config_fields(cfg);
  for (const auto& f : fields)
    if (f.name == name) return set_config_field(f, text);
  unknown_name(fields, name);
}

void set_config_field(const ConfigField& field, const std::string& text) {
  const std::string got = ", got \"" + text + "\"";
  if (auto* d = std::get_if<double*>(&field.value)) {
    double v = 0;
    if (!parse_double(text, v)) throw Error(field.name + " takes " + config_field_type(field) + " (such as 0.5 or 1e-3)" + got);
    **d = v;
  } else if (auto* i = std::get_if<int*>(&field.value)) {
    parse_whole(field, text, **i);
  } else if (auto* n = std::get_if<std::size_t*>(&field.value)) {
    parse_whole(field, text, **n);
  } else if (auto* b = std::get_if<bool*>(&field.value)) {
    const std::string t = lower(text);
    if (t == "true" || t == "1" || t == "on" || t == "yes")
      **b = true;
    else if (t == "false" || t == "0" || t == "off" || t == "no")
      **b = false;
    else
      throw Error(field.name + " takes " + config_field_type(field) + " (or 1/0, on/off, yes/no)" + got);
  } else {
    *std::get<std::string*>(field.value) = text;
  }
}

std::string config_field_text(const ConfigField& field) {
  return std::visit(
      [](auto* p) -> std::string {
        using T = std::remove_pointer_t<decltype(p)>;
        if constexpr (std::is_same_v<T, double>) {
          char buf[64];  // the shortest text that reads back to the same double
          const auto res = std::to_chars(buf, buf + sizeof buf, *p);
          return std::string(buf, res.ptr);
        } else if constexpr (std::is_same_v<T, bool>) {
          return *p ? "true" : "false";
        } else if constexpr (std::is_same_v<T, std::string>) {
          return *p;
        } else {
          return std::to_string(*p);
        }
      },
      field.value);
}

const char* config_field_type(const ConfigField& field) {
  switch (field.value.index()) {
    case 0:
      return "a number";
    case 1:
      return "a whole number";
    case 2:
      return "true or false";
    case 3:
      return "a whole number >= 0";
    default:
      return "text";
  }
}

namespace {

// The settings pl-localize sets itself from its options and the drive: the map source (set after
// --set is applied) and the beams (which also decide whether the rings are handed over). --set
// refuses them: it would be overruled silently, or contradict the drive.
const char* owner_of_setting(const std::string& name) {
  if (name == "localizer/scan/beams") return "--beams";
  if (name == "localizer/scan/sensor_beams") return "the drive's sensor";
  if (name == "tiles/server") return "--server";
  if (name == "store_path") return "--db";
  if (name == "tiles/map") return "--map";
  return nullptr;
}

}  // namespace

std::string setting_problem(const std::string& text) {
  const auto eq = text.find('=');
  if (eq == std::string::npos)
    return "--set takes NAME=VALUE, got \"" + text + "\"; pl-localize --list-settings lists the names";
  const std::string name = text.substr(0, eq);
  if (const char* owner = owner_of_setting(name))
    return "--set " + name + ": pl-localize sets it from " + owner + "; use that instead";
  VehicleLocalizerConfig scratch;
  const auto fields = config_fields(scratch);
  const auto field = std::find_if(fields.begin(), fields.end(), [&](const auto& f) { return f.name == name; });
  try {
    set_config_field(scratch, name, text.substr(eq + 1));
  } catch (const Error& e) {
    // "--set X takes a number, got ..." names the setting already; an unknown name points at the list.
    return field != fields.end() ? std::string("--set ") + e.what()
                                 : std::string("--set: ") + e.what() + "; pl-localize --list-settings lists them all";
  }
  // Its range (a setting against another, such as min_range_m below max_range_m, is checked when
  // the localizer is made, with every --set applied).
  const std::string problem = config_field_range_problem(*field);
  return problem.empty() ? "" : "--set " + problem;
}

void apply_settings(VehicleLocalizerConfig& cfg, const std::vector<std::string>& settings) {
  for (const std::string& s : settings) {
    const auto eq = s.find('=');
    set_config_field(cfg, s.substr(0, eq), s.substr(eq + 1));
  }
}

std::string settings_list(VehicleLocalizerConfig cfg, const std::vector<std::string>& settings) {
  apply_settings(cfg, settings);
  const auto fields = config_fields(cfg);
  std::vector<std::string> lefts;
  std::size_t width = 0;
  for (const auto& f : fields) {
    lefts.push_back(f.name + "=" + config_field_text(f));
    width = std::max(width, lefts.back().size());
  }
  std::string list;
  for (std::size_t i = 0; i < fields.size(); ++i) {
    const char* owner = owner_of_setting(fields[i].name);
    list += lefts[i] + std::string(width - lefts[i].size(), ' ') + "  " + fields[i].help + " (" + config_field_type(fields[i]) +
            (owner ? std::string("; pl-localize sets it from ") + owner : std::string()) + ")\n";
  }
  return list;
}

}  // namespace pl::client

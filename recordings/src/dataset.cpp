#include "pl/recordings/dataset.hpp"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <filesystem>
#include <map>

#include "dataset_recording.hpp"
#include "pl/lidar/pcap.hpp"
#include "pl/common/cloud_io.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/recordings/bag.hpp"

namespace fs = std::filesystem;

namespace pl {

const char* gps_status_name(int status) {
  switch (status) {
    case kGpsSingle: return "single";
    case kGpsDgps: return "dgps";
    case kGpsFloat: return "rtk-float";
    case kGpsFixed: return "rtk-fixed";
    default: return "none";
  }
}

const char* Dataset::layout_name() const {
  switch (layout) {
    case DatasetLayout::KittiRaw: return "KITTI raw";
    case DatasetLayout::Recording: return "recording";
    case DatasetLayout::Frames: return "PCD/PLY frames";
    default: return "KITTI odometry";
  }
}

Scan Dataset::load_scan(std::size_t i) const {
  if (recording) return recording_frame(*recording, i, false).scan;
  if (i >= scan_paths.size()) throw Error("scan index " + std::to_string(i) + " out of range (dataset has " + std::to_string(scan_paths.size()) + " scans)");
  if (layout != DatasetLayout::Frames) return read_kitti_bin(scan_paths[i]);
  const Cloud cloud = read_cloud(scan_paths[i]);
  Scan scan(cloud.size());
  for (std::size_t k = 0; k < cloud.size(); ++k) {
    const Eigen::Vector3d& q = cloud.points[k];
    scan[k] = {static_cast<float>(q.x()), static_cast<float>(q.y()), static_cast<float>(q.z()), cloud.intensity.empty() ? 0.0f : cloud.intensity[k]};
  }
  return scan;
}

Frame Dataset::load_frame(std::size_t i, bool with_rings) const {
  if (recording) return recording_frame(*recording, i, with_rings);  // rings only from a ring field
  Frame f;
  f.scan = load_scan(i);
  // Frames saved as clouds carry no rings; a meta.json with the sensor's vertical angles gives them.
  if (with_rings && !(layout == DatasetLayout::Frames && meta.sensor.vertical_angles_deg.empty())) f.rings = rings(f.scan);
  f.times = load_point_times(i, f.scan.size());
  return f;
}

std::vector<float> Dataset::load_point_times(std::size_t i, std::size_t points) const {
  if (recording) {
    std::vector<float> t = recording_frame(*recording, i, false).times;
    if (!t.empty() && t.size() != points)
      throw Error(dir + ": scan " + std::to_string(i) + " has " + std::to_string(t.size()) + " point times for " + std::to_string(points) + " points");
    return t;
  }
  if (i >= scan_paths.size()) throw Error("scan index " + std::to_string(i) + " out of range (dataset has " + std::to_string(scan_paths.size()) + " scans)");
  if (!has_point_times()) return {};
  const std::string& scan = scan_paths[i];
  const std::string path = point_times_dir + "/" + scan.substr(scan.find_last_of('/') + 1);
  if (!file_exists(path))
    throw Error(path + ": missing: " + point_times_dir + " holds per-point times, one file per scan named as the scan "
                "(add it, or remove the folder to use the points' azimuths)");
  return read_point_times(path, points);
}

std::vector<std::uint16_t> Dataset::rings(const Scan& scan) const {
  if (meta.sensor.point_order == "laser-by-laser") return rings_from_azimuth(scan);
  return rings_from_elevation(scan, meta.sensor.vertical_angles_deg);
}

Eigen::Vector3d Dataset::to_world(const GeoPoint& p) const {
  switch (projection.kind) {
    case WorldProjection::Kind::Enu: return projection.world_from_projected * EnuFrame(projection.origin).to_enu(p);
    case WorldProjection::Kind::KittiMercator: {
      Eigen::Vector2d m = kitti_mercator(p.lat_deg, p.lon_deg, projection.mercator_scale);
      return projection.world_from_projected * Eigen::Vector3d(m.x(), m.y(), p.alt_m);
    }
    default: break;
  }
  throw Error(dir + ": GPS positions cannot be placed in the world frame: add \"origin\" {lat, lon, alt} to meta.json");
}

bool parse_kitti_timestamp_ns(const std::string& text, std::int64_t& ns) {
  int y, mo, d, h, mi, whole, used = 0;
  // Field widths keep every number within int (sscanf's %d on more digits is undefined), and the
  // year within 4 digits keeps the day count below from overflowing. The seconds are read as digits,
  // not as a double, so that the time is exact to the nanosecond (a recording's stamps are integers).
  if (std::sscanf(text.c_str(), "%4d-%2d-%2d %2d:%2d:%2d%n", &y, &mo, &d, &h, &mi, &whole, &used) != 6) return false;
  if (y < 0 || mo < 1 || mo > 12 || d < 1 || d > 31 || h < 0 || h > 23 || mi < 0 || mi > 59 || whole < 0 || whole > 60) return false;
  if (!std::isdigit(static_cast<unsigned char>(text[static_cast<std::size_t>(used) - 1]))) return false;  // "%2d" took a sign only
  std::int64_t frac = 0;
  std::size_t i = static_cast<std::size_t>(used);
  if (i < text.size() && text[i] == '.') {
    int digits = 0;
    for (++i; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i, ++digits)
      if (digits < 9) frac = frac * 10 + (text[i] - '0');
    if (digits == 0) return false;
    for (; digits < 9; ++digits) frac *= 10;
  }
  while (i < text.size() && (text[i] == ' ' || text[i] == '\t' || text[i] == '\r')) ++i;
  if (i != text.size()) return false;  // "1e400", "nan" and other tails
  // Days from the civil date (proleptic Gregorian), so runs across midnight or month ends stay monotonic.
  y -= mo <= 2;
  long era = (y >= 0 ? y : y - 399) / 400;
  long yoe = y - era * 400;
  long doy = (153 * (mo + (mo > 2 ? -3 : 9)) + 2) / 5 + d - 1;
  long doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
  long days = era * 146097 + doe - 719468;
  const std::int64_t seconds = static_cast<std::int64_t>(days) * 86400 + h * 3600 + mi * 60 + whole;
  // Nanoseconds since 1970 in 64 bits reach 1677 to 2262: beyond that no recording's clock can be.
  constexpr std::int64_t kMaxSeconds = 9000000000LL;
  if (seconds > kMaxSeconds || seconds < -kMaxSeconds) return false;
  ns = seconds * 1000000000LL + frac;
  return true;
}

bool parse_kitti_timestamp(const std::string& text, double& seconds) {
  std::int64_t ns = 0;
  if (!parse_kitti_timestamp_ns(text, ns)) return false;
  seconds = ns_to_seconds(ns);
  return true;
}

namespace {

// Scans in a folder: NNN.bin files ordered by their number.
void list_scans(const std::string& folder, Dataset& ds) {
  std::vector<std::pair<long, std::string>> found;
  for (const auto& e : fs::directory_iterator(folder)) {
    if (!e.is_regular_file() || e.path().extension() != ".bin") continue;
    long long id = 0;
    std::string stem = e.path().stem().string();
    if (!parse_int(stem, id) || id < 0)
      throw Error(e.path().string() + ": scan files must be named by their frame number (e.g. 000042.bin)");
    found.emplace_back(static_cast<long>(id), e.path().string());
  }
  if (found.empty()) {
    bool compressed = false;
    for (const auto& e : fs::directory_iterator(folder)) compressed |= e.path().extension() == ".xz";
    throw Error(folder + ": no .bin scans" +
                (compressed ? std::string(" (the scans are .xz-compressed: expand them with ../shared/data/unpack.sh DEST)") : ""));
  }
  std::sort(found.begin(), found.end());
  // 42.bin and 000042.bin would both be frame 42: one time, one pose, one OXTS record for two scans.
  for (std::size_t i = 1; i < found.size(); ++i)
    if (found[i].first == found[i - 1].first)
      throw Error(found[i - 1].second + " and " + found[i].second + " are both frame " + std::to_string(found[i].first) +
                  ": keep one scan per frame number");
  for (auto& [id, path] : found) {
    ds.frame_ids.push_back(id);
    ds.scan_paths.push_back(std::move(path));
  }
}

// Every line of a file as `count` numbers (the line index is the frame number), row after row in one
// array: a vector per line would cost some 50 bytes of memory for every 2-byte line of times.txt.
struct NumberRows {
  std::vector<double> values;
  std::size_t count = 0;
  std::size_t size() const { return values.size() / count; }
  std::vector<double> row(std::size_t i) const {
    return std::vector<double>(values.begin() + static_cast<std::ptrdiff_t>(i * count),
                               values.begin() + static_cast<std::ptrdiff_t>((i + 1) * count));
  }
};

NumberRows read_number_lines(const std::string& path, std::size_t count, const std::string& what) {
  LineReader reader(path);
  NumberRows out;
  out.count = count;
  std::string line;
  while (reader.next(line)) {
    const auto v = parse_numbers(reader, line, count, count, what, " \t\r");
    out.values.insert(out.values.end(), v.begin(), v.end());
  }
  return out;
}

// A pose made from a file's numbers: huge values pass the parser but overflow in the conversion.
void check_finite_pose(const Pose& p, const std::string& where) {
  if (!p.matrix().allFinite())
    throw Error(where + " is not finite after the conversion (values out of range?)");
}

// "KEY: 12 numbers" from a KITTI calibration file.
std::optional<Pose> read_calib_entry(const std::string& path, const std::string& key) {
  LineReader reader(path);
  std::string line;
  while (reader.next(line)) {
    if (line.rfind(key + ":", 0) != 0) continue;
    auto v = parse_numbers(reader, line.substr(key.size() + 1), 12, 12, key + ": the row-major 3x4 transform", " \t\r");
    return pose_from_kitti_row(v);
  }
  return std::nullopt;
}

// A CSV sidecar: an optional header naming the columns, then rows of numbers in non-decreasing time.
template <typename Fn>
void read_csv_sidecar(const std::string& path, const std::vector<std::string>& columns, Fn&& row) {
  LineReader reader(path);
  std::string line, header;
  for (std::size_t i = 0; i < columns.size(); ++i) header += (i ? "," : "") + columns[i];
  bool first = true;
  double last_t = -INFINITY;
  while (reader.next(line)) {
    if (first) {
      first = false;
      if (std::isalpha(static_cast<unsigned char>(line[line.find_first_not_of(" \t")]))) {
        auto names = split_fields(line, " \t\r,");
        bool same = names.size() == columns.size();
        for (std::size_t i = 0; same && i < names.size(); ++i) same = names[i] == columns[i];
        if (!same) reader.fail("the header \"" + header + "\"", line);
        continue;
      }
    }
    auto v = parse_numbers(reader, line, columns.size(), columns.size(), header, ",");
    if (v[0] < last_t) reader.fail("times in non-decreasing order (previous t = " + std::to_string(last_t) + ")", line);
    last_t = v[0];
    row(v, reader, line);
  }
}

}  // namespace

int gps_status_from_oxts(int posmode) {
  switch (posmode) {
    case 3: case 13: case 21: return kGpsSingle;
    case 4: case 7: case 8: case 14: case 17: case 18: case 22: return kGpsDgps;
    case 5: case 9: case 15: case 23: return kGpsFloat;
    case 6: case 16: case 24: return kGpsFixed;
    default: return kGpsNone;
  }
}

namespace {

void open_odometry_layout(Dataset& ds) {
  ds.layout = DatasetLayout::KittiOdometry;
  list_scans(ds.dir + "/velodyne", ds);
  std::string times_path = ds.dir + "/times.txt";
  if (!file_exists(times_path)) throw Error(times_path + ": missing (one time in seconds per frame)");
  auto times = read_number_lines(times_path, 1, "the frame's time in seconds");
  long last = ds.frame_ids.back();
  if (static_cast<long>(times.size()) <= last)
    throw Error(times_path + ": has " + std::to_string(times.size()) + " lines but scan " + std::to_string(last) +
                " needs line " + std::to_string(last + 1));
  for (long id : ds.frame_ids) ds.times.push_back(times.values[static_cast<std::size_t>(id)]);

  std::string poses_path = ds.dir + "/poses.txt";
  if (file_exists(poses_path)) {
    auto rows = read_number_lines(poses_path, 12, "a KITTI pose: the row-major 3x4 matrix");
    if (static_cast<long>(rows.size()) <= last)
      throw Error(poses_path + ": has " + std::to_string(rows.size()) + " poses but scan " + std::to_string(last) +
                  " needs line " + std::to_string(last + 1));
    std::string calib_path = ds.dir + "/calib.txt";
    Pose tr = Pose::Identity();  // velo -> cam0
    bool cam0 = false;
    if (file_exists(calib_path)) {
      auto entry = read_calib_entry(calib_path, "Tr");
      if (!entry) throw Error(calib_path + ": no \"Tr:\" line (the LiDAR-to-cam0 transform, 12 numbers)");
      tr = *entry;
      check_finite_pose(tr, calib_path + ": the Tr: transform");
      cam0 = true;
    }
    ds.ground_truth.format = PoseFormat::Kitti;
    for (long id : ds.frame_ids) {
      Pose p = pose_from_kitti_row(rows.row(static_cast<std::size_t>(id)));
      ds.ground_truth.poses.push_back(cam0 ? Pose(tr.inverse() * p * tr) : p);
      check_finite_pose(ds.ground_truth.poses.back(), poses_path + ": the pose of frame " + std::to_string(id));
    }
    ds.ground_truth.times = ds.times;
  }
}

// A number for a message: short, whatever its magnitude.
std::string num(double v) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "%.10g", v);
  return buf;
}

std::string oxts_path(const Dataset& ds, long id) {
  char name[32];
  std::snprintf(name, sizeof(name), "%010ld.txt", id);
  return ds.dir + "/oxts/data/" + name;
}

// The values the conversion to poses and fixes relies on: a latitude the Mercator projection can
// take (at +-90 degrees it is infinite), a longitude, and an accuracy that is a standard deviation.
void check_oxts_record(const std::vector<double>& o, const std::string& path) {
  if (!(std::abs(o[0]) < 90.0) || !(std::abs(o[1]) <= 180.0))
    throw Error(path + ": expected lat in (-90, 90) and lon in [-180, 180] degrees (the first two values), found " +
                num(o[0]) + " " + num(o[1]));
  if (o[23] < 0) throw Error(path + ": expected pos_accuracy (value 24) >= 0, found " + num(o[23]));
}

// The position mode (value 28) as an int: a value that is no mode at all maps to none (-1), rather
// than through a float-to-int conversion that is undefined out of range.
int oxts_posmode(double v) { return v >= 0 && v <= 1000 && v == std::floor(v) ? static_cast<int>(v) : -1; }

// Clouds saved frame by frame (PCL's pcl_recorder, Open3D, a driver's dump): DIR/*.pcd or *.ply in
// name order (by number when every name is one), their times in times.txt (one a line, seconds), or
// times and ground-truth LiDAR poses in poses.tum; poses.txt (KITTI, one a frame) gives the ground
// truth beside times.txt.
bool has_cloud_frames(const std::string& dir) {
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string ext = e.path().extension().string();
    if (e.is_regular_file() && (ext == ".pcd" || ext == ".ply")) return true;
  }
  return false;
}

void open_frames_layout(Dataset& ds) {
  ds.layout = DatasetLayout::Frames;
  std::vector<std::string> files;
  bool numbered = true;
  for (const auto& e : fs::directory_iterator(ds.dir)) {
    const std::string ext = e.path().extension().string();
    if (!e.is_regular_file() || (ext != ".pcd" && ext != ".ply")) continue;
    files.push_back(e.path().string());
    long long id = 0;
    numbered = numbered && parse_int(e.path().stem().string(), id) && id >= 0;
  }
  std::sort(files.begin(), files.end(), [&](const std::string& a, const std::string& b) {
    if (!numbered) return a < b;
    long long x = 0, y = 0;
    parse_int(fs::path(a).stem().string(), x);
    parse_int(fs::path(b).stem().string(), y);
    return x != y ? x < y : a < b;
  });
  for (std::size_t i = 0; i < files.size(); ++i) {
    ds.scan_paths.push_back(files[i]);
    ds.frame_ids.push_back(static_cast<long>(i));
  }
  const std::size_t n = files.size();
  const std::string times_path = ds.dir + "/times.txt", tum_path = ds.dir + "/poses.tum", kitti_path = ds.dir + "/poses.txt";
  auto count_error = [&](const std::string& path, std::size_t lines, const char* what) {
    return Error(path + ": has " + std::to_string(lines) + " " + what + " for " + std::to_string(n) + " frames (" + ds.dir +
                 "'s .pcd/.ply files in name order): give one a frame");
  };
  if (file_exists(times_path)) {
    const auto times = read_number_lines(times_path, 1, "the frame's time in seconds");
    if (times.size() != n) throw count_error(times_path, times.size(), "times");
    for (std::size_t i = 0; i < n; ++i) ds.times.push_back(times.values[i]);
  }
  if (file_exists(tum_path)) {
    Trajectory tum = read_tum_poses(tum_path);
    if (tum.size() != n) throw count_error(tum_path, tum.size(), "poses");
    if (ds.times.empty()) ds.times = tum.times;
    ds.ground_truth = std::move(tum);
    ds.ground_truth.times = ds.times;
  } else if (file_exists(kitti_path)) {
    const auto rows = read_number_lines(kitti_path, 12, "a KITTI pose: the row-major 3x4 matrix");
    if (rows.size() != n) throw count_error(kitti_path, rows.size(), "poses");
    ds.ground_truth.format = PoseFormat::Kitti;
    for (std::size_t i = 0; i < n; ++i) {
      ds.ground_truth.poses.push_back(pose_from_kitti_row(rows.row(i)));
      check_finite_pose(ds.ground_truth.poses.back(), kitti_path + ": the pose of frame " + std::to_string(i));
    }
  }
  if (ds.times.empty())
    throw Error(ds.dir + ": " + std::to_string(n) + " cloud frames but no times: add times.txt (one time in seconds a frame, in name "
                "order) or poses.tum (TUM: the time and the LiDAR's pose of each frame)");
  if (!ds.ground_truth.poses.empty()) ds.ground_truth.times = ds.times;
  for (std::size_t i = 1; i < n; ++i)
    if (!(ds.times[i] > ds.times[i - 1]))
      throw Error(ds.dir + ": frame " + std::to_string(i) + " (" + files[i] + ") is not later than the frame before it; the times must grow in name order");
  // Rings come only from a meta.json with the sensor's vertical angles.
  ds.meta.sensor.model = "cloud frames";
  ds.meta.sensor.beams = 1;
  ds.meta.sensor.point_order = "any";
  ds.meta.sensor.vertical_angles_deg.clear();
}

void open_raw_layout(Dataset& ds) {
  ds.layout = DatasetLayout::KittiRaw;
  list_scans(ds.dir + "/velodyne_points/data", ds);
  std::size_t n = ds.scan_paths.size();

  // Times: the LiDAR's own timestamps when present, otherwise the (synchronised) OXTS ones.
  std::string ts_path = ds.dir + "/velodyne_points/timestamps.txt";
  if (!file_exists(ts_path)) ts_path = ds.dir + "/oxts/timestamps.txt";
  {
    LineReader reader(ts_path);
    std::string line;
    std::vector<double> all;
    while (reader.next(line)) {
      double s = 0;
      if (!parse_kitti_timestamp(line, s)) reader.fail("a timestamp like 2011-09-26 13:04:32.349659964", line);
      all.push_back(s);
    }
    if (all.size() <= static_cast<std::size_t>(ds.frame_ids.back()))
      throw Error(ts_path + ": has " + std::to_string(all.size()) + " timestamps but scan " + std::to_string(ds.frame_ids.back()) + " needs one");
    // Absolute, the recording's clock (seconds since 1970), as a recording of the same drive gives them.
    for (long id : ds.frame_ids) ds.times.push_back(all[id]);
  }

  // OXTS: one file of 30 numbers per frame.
  std::string calib_path = ds.dir + "/calib_imu_to_velo.txt";
  if (!file_exists(calib_path)) throw Error(calib_path + ": missing (R: 9 numbers, T: 3 numbers; X_velo = R X_imu + T)");
  Pose imu_to_velo = Pose::Identity();
  {
    LineReader reader(calib_path);
    std::string line;
    bool have_r = false, have_t = false;
    while (reader.next(line)) {
      if (line.rfind("R:", 0) == 0) {
        auto v = parse_numbers(reader, line.substr(2), 9, 9, "R: the row-major 3x3 rotation", " \t\r");
        Eigen::Matrix3d r;
        r << v[0], v[1], v[2], v[3], v[4], v[5], v[6], v[7], v[8];
        imu_to_velo.linear() = orthonormalize(r);
        have_r = true;
      } else if (line.rfind("T:", 0) == 0) {
        auto v = parse_numbers(reader, line.substr(2), 3, 3, "T: the translation in metres", " \t\r");
        imu_to_velo.translation() = Eigen::Vector3d(v[0], v[1], v[2]);
        have_t = true;
      }
    }
    if (!have_r || !have_t) throw Error(calib_path + ": needs an \"R:\" line (9 numbers) and a \"T:\" line (3 numbers)");
    check_finite_pose(imu_to_velo, calib_path + ": the IMU-to-LiDAR transform");
  }

  std::vector<std::vector<double>> oxts;
  oxts.reserve(n);
  for (long id : ds.frame_ids) {
    const std::string path = oxts_path(ds, id);
    if (!file_exists(path)) throw Error(path + ": missing (every scan needs its OXTS record)");
    auto rows = read_number_lines(path, 30, "an OXTS record: lat lon alt roll pitch yaw ... (30 values, see oxts/dataformat.txt)");
    if (rows.size() != 1) throw Error(path + ": expected exactly one line of 30 numbers");
    check_oxts_record(rows.values, path);
    oxts.push_back(std::move(rows.values));
  }

  double scale = std::cos(oxts[0][0] * M_PI / 180.0);
  auto imu_pose = [&](const std::vector<double>& o) {
    Eigen::Vector2d m = kitti_mercator(o[0], o[1], scale);
    return make_pose(m.x(), m.y(), o[2], o[3], o[4], o[5]);
  };
  Pose first_inv = imu_pose(oxts[0]).inverse();
  Pose velo_to_imu = imu_to_velo.inverse();
  ds.ground_truth.format = PoseFormat::Kitti;
  for (std::size_t i = 0; i < n; ++i) {
    ds.ground_truth.poses.push_back(imu_to_velo * first_inv * imu_pose(oxts[i]) * velo_to_imu);
    check_finite_pose(ds.ground_truth.poses.back(), oxts_path(ds, ds.frame_ids[i]) + ": the pose of this record");
  }
  ds.ground_truth.times = ds.times;

  ds.projection.kind = WorldProjection::Kind::KittiMercator;
  ds.projection.origin = {oxts[0][0], oxts[0][1], oxts[0][2]};
  ds.projection.mercator_scale = scale;
  ds.projection.world_from_projected = imu_to_velo * first_inv;
  check_finite_pose(ds.projection.world_from_projected, oxts_path(ds, ds.frame_ids[0]) + ": the world frame from this record");

  for (std::size_t i = 0; i < n; ++i) {
    const auto& o = oxts[i];
    ds.gps.push_back({ds.times[i], {o[0], o[1], o[2]}, o[23], gps_status_from_oxts(oxts_posmode(o[27]))});
  }

  ds.meta.sensor.vertical_angles_deg = hdl64_vertical_angles_deg();
  ds.meta.vehicle.gps_lever_arm = imu_to_velo.translation();  // the OXTS antenna/IMU in the LiDAR frame
  ds.meta.origin = ds.projection.origin;
}

}  // namespace

Dataset open_dataset(const std::string& dir_in, const DatasetOptions& options) {
  if (bag::is_recording(dir_in)) return open_recording(dir_in, options);
  if (lidar::is_pcap(dir_in)) return open_pcap_recording(dir_in, options);
  Dataset ds;
  ds.dir = dir_in;
  while (ds.dir.size() > 1 && ds.dir.back() == '/') ds.dir.pop_back();
  if (!dir_exists(ds.dir)) {
    if (file_exists(ds.dir))
      throw Error(ds.dir + ": not a dataset: expected a KITTI folder, a ROS 1 bag (.bag), a ROS 2 bag (a folder with metadata.yaml, or a .db3 file) or an MCAP file");
    throw Error(ds.dir + ": no such folder");
  }
  ds.meta.sensor.vertical_angles_deg = hdl64_vertical_angles_deg();

  if (dir_exists(ds.dir + "/velodyne_points/data") && dir_exists(ds.dir + "/oxts/data"))
    open_raw_layout(ds);
  else if (dir_exists(ds.dir + "/velodyne"))
    open_odometry_layout(ds);
  else if (has_cloud_frames(ds.dir))
    open_frames_layout(ds);
  else
    throw Error(ds.dir + ": not a dataset: expected velodyne/ (KITTI odometry layout), velodyne_points/data/ and oxts/data/ (KITTI raw "
                "layout), .pcd or .ply frames with times.txt or poses.tum, or a recording (a .bag, a ROS 2 bag folder, a .mcap)");

  std::string meta_path = ds.dir + "/meta.json";
  if (file_exists(meta_path)) {
    ds.meta = read_meta(meta_path);
    ds.has_meta_file = true;
    ds.sidecars.push_back("meta.json");
    if (ds.meta.sensor.vertical_angles_deg.empty() && ds.meta.sensor.beams == 64)
      ds.meta.sensor.vertical_angles_deg = hdl64_vertical_angles_deg();
    if (ds.meta.origin && ds.layout == DatasetLayout::KittiOdometry) {
      ds.projection.kind = WorldProjection::Kind::Enu;
      ds.projection.origin = *ds.meta.origin;
    }
  }

  if (dir_exists(ds.dir + "/point_times")) {
    ds.point_times_dir = ds.dir + "/point_times";
    ds.sidecars.push_back("point_times/");
  }
  std::string gps_path = ds.dir + "/gps.csv";
  if (file_exists(gps_path)) {  // a sidecar replaces the OXTS stream (e.g. a degraded receiver)
    ds.gps.clear();
    read_csv_sidecar(gps_path, {"t", "lat", "lon", "alt", "std_m", "status"},
                     [&](const std::vector<double>& v, const LineReader& r, const std::string& line) {
                       if (v[5] < 0 || v[5] > 4 || v[5] != std::floor(v[5]))
                         r.fail("status 0 (none), 1 (single), 2 (dgps), 3 (rtk-float) or 4 (rtk-fixed)", line);
                       if (std::abs(v[1]) > 90 || std::abs(v[2]) > 180) r.fail("lat in [-90, 90] and lon in [-180, 180] degrees", line);
                       if (v[4] < 0) r.fail("std_m >= 0", line);
                       ds.gps.push_back({v[0], {v[1], v[2], v[3]}, v[4], static_cast<int>(v[5])});
                     });
    ds.sidecars.push_back("gps.csv");
  }
  std::string enc_path = ds.dir + "/encoder.csv";
  if (file_exists(enc_path)) {
    read_csv_sidecar(enc_path, {"t", "left_m", "right_m"},
                     [&](const std::vector<double>& v, const LineReader&, const std::string&) {
                       ds.encoder.push_back({v[0], v[1], v[2]});
                     });
    ds.sidecars.push_back("encoder.csv");
  }
  std::string odo_path = ds.dir + "/odometry.csv";
  if (file_exists(odo_path)) {
    read_csv_sidecar(odo_path, {"t", "x", "y", "z", "qx", "qy", "qz", "qw"},
                     [&](const std::vector<double>& v, const LineReader& r, const std::string& line) {
                       Eigen::Quaterniond q(v[7], v[4], v[5], v[6]);
                       if (!(q.norm() > 0.5 && q.norm() < 1.5)) r.fail("a unit quaternion in qx,qy,qz,qw", line);
                       OdometrySample s{v[0], Pose::Identity()};
                       s.pose.linear() = q.normalized().toRotationMatrix();
                       s.pose.translation() = Eigen::Vector3d(v[1], v[2], v[3]);
                       ds.odometry.push_back(s);
                     });
    ds.sidecars.push_back("odometry.csv");
  }
  if (!ds.encoder.empty() && !(ds.meta.vehicle.wheel_base_m > 0))
    throw Error(meta_path + ": encoder.csv needs \"vehicle\": {\"wheel_base_m\": ...} in meta.json to turn wheel travel into motion");
  // The same truth read from a recording (a quaternion written from this rotation) gives the same bits.
  for (Pose& p : ds.ground_truth.poses) p = canonical_rotation(p);
  return ds;
}

}  // namespace pl

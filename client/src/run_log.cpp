#include "pl/client/run_log.hpp"

#include <openssl/evp.h>

#include <nlohmann/json.hpp>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <unordered_set>

#include "pl/common/error.hpp"
#include "pl/common/voxel.hpp"

namespace pl::client {
namespace {

using Json = nlohmann::ordered_json;

// --- JSON Schemas ---------------------------------------------------------------------------------
// Foxglove recognises a schema by its name; the documents below describe the fields as Foxglove's
// schema reference lists them (names, types, integer enums), so that other JSON Schema tools can
// check the messages too.

const char* const kTime =
    R"({"type": "object", "title": "time", "description": "An instant: seconds and nanoseconds since the Unix epoch",
       "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}},
       "required": ["sec", "nsec"]})";

std::string vector3(const char* description) {
  return std::string(R"({"title": "foxglove.Vector3", "type": "object", "description": ")") + description +
         R"(", "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}},
       "required": ["x", "y", "z"]})";
}

std::string quaternion(const char* description) {
  return std::string(R"({"title": "foxglove.Quaternion", "type": "object", "description": ")") + description +
         R"(", "properties": {"x": {"type": "number"}, "y": {"type": "number"}, "z": {"type": "number"}, "w": {"type": "number"}},
       "required": ["x", "y", "z", "w"]})";
}

std::string pose_schema(const char* description) {
  return std::string(R"({"title": "foxglove.Pose", "type": "object", "description": ")") + description +
         R"(", "properties": {"position": )" + vector3("metres") + R"(, "orientation": )" + quaternion("unit quaternion") +
         R"(}, "required": ["position", "orientation"]})";
}

std::string pose_in_frame_schema() {
  return std::string(R"({"title": "foxglove.PoseInFrame", "type": "object",
  "description": "The fused pose of the vehicle's base in the map frame, from a PointLocalization run log",
  "properties": {"timestamp": )") + kTime + R"(, "frame_id": {"type": "string"}, "pose": )" +
         pose_schema("the base in frame_id") + R"(},
  "required": ["timestamp", "frame_id", "pose"]})";
}

std::string frame_transform_schema() {
  return std::string(R"({"title": "foxglove.FrameTransform", "type": "object",
  "description": "Where the child frame is in the parent frame at an instant",
  "properties": {"timestamp": )") + kTime + R"(, "parent_frame_id": {"type": "string"}, "child_frame_id": {"type": "string"},
  "translation": )" + vector3("the child's origin in the parent frame, metres") + R"(, "rotation": )" +
         quaternion("the child's orientation in the parent frame") + R"(},
  "required": ["timestamp", "parent_frame_id", "child_frame_id", "translation", "rotation"]})";
}

std::string point_cloud_schema() {
  return std::string(R"({"title": "foxglove.PointCloud", "type": "object",
  "description": "Points packed in data, each point_stride bytes, laid out as fields says",
  "properties": {"timestamp": )") + kTime + R"(, "frame_id": {"type": "string"}, "pose": )" +
         pose_schema("the cloud's origin in frame_id") + R"(,
    "point_stride": {"type": "integer", "minimum": 0},
    "fields": {"type": "array", "items": {"title": "foxglove.PackedElementField", "type": "object",
      "properties": {"name": {"type": "string"}, "offset": {"type": "integer", "minimum": 0},
        "type": {"title": "foxglove.NumericType", "description": "little-endian",
          "oneOf": [{"title": "UNKNOWN", "const": 0}, {"title": "UINT8", "const": 1}, {"title": "INT8", "const": 2},
                    {"title": "UINT16", "const": 3}, {"title": "INT16", "const": 4}, {"title": "UINT32", "const": 5},
                    {"title": "INT32", "const": 6}, {"title": "FLOAT32", "const": 7}, {"title": "FLOAT64", "const": 8}]}},
      "required": ["name", "offset", "type"]}},
    "data": {"type": "string", "contentEncoding": "base64"}},
  "required": ["timestamp", "frame_id", "pose", "point_stride", "fields", "data"]})";
}

std::string location_fix_schema() {
  return std::string(R"({"title": "foxglove.LocationFix", "type": "object",
  "description": "A GPS fix: WGS 84 latitude and longitude in degrees, altitude in metres",
  "properties": {"timestamp": )") + kTime + R"(, "frame_id": {"type": "string"},
    "latitude": {"type": "number"}, "longitude": {"type": "number"}, "altitude": {"type": "number"},
    "position_covariance": {"type": "array", "items": {"type": "number"}, "minItems": 9, "maxItems": 9,
      "description": "east, north, up; row-major, square metres"},
    "position_covariance_type": {"title": "foxglove.PositionCovarianceType",
      "oneOf": [{"title": "UNKNOWN", "const": 0}, {"title": "APPROXIMATED", "const": 1},
                {"title": "DIAGONAL_KNOWN", "const": 2}, {"title": "KNOWN", "const": 3}]}},
  "required": ["timestamp", "latitude", "longitude", "altitude", "position_covariance", "position_covariance_type"]})";
}

// Our own: pl::client::ScanReport, the fields a person looks at when a run goes wrong.
std::string scan_report_schema() {
  return std::string(R"({"title": "pl.ScanReport", "type": "object",
  "description": "PointLocalization's report of one scan: health, protection level, the registration and its timings",
  "properties": {
    "timestamp": )") + kTime + R"(,
    "health": {"type": "string", "enum": ["ok", "degraded", "lost"]},
    "note": {"type": "string", "description": "why degraded or lost"},
    "protection_m": {"type": "number", "description": "bound on the horizontal position error"},
    "registration_sigma_m": {"type": "number", "description": "the registration's horizontal position sigma, inflated"},
    "position_sigma_m": {"type": "number", "description": "norm of the covariance proxy's position sigmas"},
    "uncertainty_m": {"type": "number", "description": "the prediction's horizontal 1-sigma uncertainty"},
    "fused": {"type": "boolean", "description": "the registration was accepted and fused"},
    "motion": {"type": "string", "description": "what predicted the scan"},
    "basin": {"type": "string", "enum": ["fine", "coarse", "search"]},
    "map_outdated": {"type": "boolean"},
    "icp": {"type": "object", "properties": {
      "iterations": {"type": "integer"}, "converged": {"type": "boolean"}, "accepted": {"type": "boolean"},
      "pairs": {"type": "integer"}, "fitness": {"type": "number", "description": "inlier share: pairs / scan points"},
      "rms_m": {"type": "number"}, "conditioning": {"type": "number"}, "reject_reason": {"type": "string"}},
      "required": ["iterations", "fitness", "rms_m"]},
    "scan_points": {"type": "integer"}, "map_tiles": {"type": "integer"}, "map_points": {"type": "integer"},
    "timing_ms": {"type": "object", "properties": {
      "prepare": {"type": "number"}, "map": {"type": "number"}, "register": {"type": "number"},
      "odometry": {"type": "number"}, "integrity": {"type": "number"},
      "total": {"type": "number", "description": "the whole scan, wall clock; absent when not measured"}},
      "required": ["prepare", "map", "register", "integrity"]}},
  "required": ["timestamp", "health", "note", "protection_m", "registration_sigma_m", "icp", "map_tiles", "map_points", "timing_ms"]})";
}

// --- Values ---------------------------------------------------------------------------------------

std::uint64_t to_ns(double t, const std::string& path) {
  if (!std::isfinite(t) || t < 0 || t > 9.2e9)
    throw Error(path + ": a time of " + std::to_string(t) + " s cannot be logged: MCAP times are nanoseconds since 1970, "
                "0 to 2262 (give the drive absolute times, or times from 0)");
  return static_cast<std::uint64_t>(std::llround(t * 1e9));
}

Json stamp(std::uint64_t ns) {
  return Json{{"sec", ns / 1000000000ull}, {"nsec", ns % 1000000000ull}};
}

Json xyz(const Eigen::Vector3d& v) { return Json{{"x", v.x()}, {"y", v.y()}, {"z", v.z()}}; }

// As the pose files write it: w >= 0.
Json xyzw(const Eigen::Matrix3d& r) {
  Eigen::Quaterniond q(r);
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return Json{{"x", q.x()}, {"y", q.y()}, {"z", q.z()}, {"w", q.w()}};
}

Json pose_json(const Eigen::Isometry3d& p) { return Json{{"position", xyz(p.translation())}, {"orientation", xyzw(p.linear())}}; }

// Base64 as Foxglove's JSON encoding carries bytes (OpenSSL's encoder, no line breaks).
std::string base64(const std::string& bytes) {
  std::string out(4 * ((bytes.size() + 2) / 3) + 1, '\0');
  const int n = EVP_EncodeBlock(reinterpret_cast<unsigned char*>(out.data()), reinterpret_cast<const unsigned char*>(bytes.data()),
                                static_cast<int>(bytes.size()));
  out.resize(static_cast<std::size_t>(n));
  return out;
}

// x, y, z as float32, 12 bytes a point (no intensity: a quarter more bytes for a colour Foxglove
// can take from the height as well).
constexpr std::uint32_t kStride = 12;
void pack(std::string& out, const Eigen::Vector3d& p) {
  const float v[3] = {static_cast<float>(p.x()), static_cast<float>(p.y()), static_cast<float>(p.z())};
  out.append(reinterpret_cast<const char*>(v), sizeof v);
}

Json cloud_json(std::uint64_t ns, const std::string& frame, const std::string& packed) {
  Json fields = Json::array();
  const char* names[3] = {"x", "y", "z"};
  for (std::uint32_t k = 0; k < 3; ++k) fields.push_back(Json{{"name", names[k]}, {"offset", 4 * k}, {"type", 7}});  // FLOAT32
  return Json{{"timestamp", stamp(ns)},
              {"frame_id", frame},
              {"pose", pose_json(Eigen::Isometry3d::Identity())},
              {"point_stride", kStride},
              {"fields", fields},
              {"data", base64(packed)}};
}

// One point per voxel of the tile (its first), packed.
std::string thinned_tile(const TileCloud& cloud, double voxel_m) {
  std::string out;
  std::unordered_set<VoxelIndex, VoxelIndexHash> seen;
  seen.reserve(cloud.size() / 4 + 16);
  const double inv = 1.0 / voxel_m;
  for (std::size_t i = 0; i < cloud.size(); ++i)
    if (voxel_m <= 0 || seen.insert(voxel_index(cloud.points[i], inv)).second) pack(out, cloud.points[i]);
  return out;
}

}  // namespace

RunLog::RunLog(const std::string& path, const RunLogOptions& options) : o_(options), writer_(path, options.mcap) {
  const auto channel = [&](const std::string& schema_name, const std::string& schema, const std::string& topic) {
    const std::uint16_t id = writer_.add_channel(writer_.add_schema(schema_name, "jsonschema", schema), topic, "json");
    counts_[topic] = 0;
    return id;
  };
  pose_ = channel("foxglove.PoseInFrame", pose_in_frame_schema(), "/pose");
  tf_ = channel("foxglove.FrameTransform", frame_transform_schema(), "/tf");
  const std::string cloud = point_cloud_schema();
  const std::uint16_t cloud_schema = writer_.add_schema("foxglove.PointCloud", "jsonschema", cloud);
  scan_ = writer_.add_channel(cloud_schema, "/scan", "json");
  map_ = writer_.add_channel(cloud_schema, "/map", "json");
  counts_["/scan"] = counts_["/map"] = 0;
  gps_ = channel("foxglove.LocationFix", location_fix_schema(), "/gps");
  health_ = channel("pl.ScanReport", scan_report_schema(), "/health");
}

RunLog::~RunLog() = default;  // the writer closes itself

void RunLog::put(std::uint16_t channel, const std::string& topic, double t, const std::string& json) {
  const std::uint64_t ns = to_ns(t, writer_.path());
  writer_.write(channel, sequence_[channel]++, ns, ns, json);
  ++counts_[topic];
}

void RunLog::pose(double t, const Eigen::Isometry3d& base_in_map) {
  const std::uint64_t ns = to_ns(t, writer_.path());
  put(pose_, "/pose", t, Json{{"timestamp", stamp(ns)}, {"frame_id", o_.map_frame}, {"pose", pose_json(base_in_map)}}.dump());
  put(tf_, "/tf", t,
      Json{{"timestamp", stamp(ns)},
           {"parent_frame_id", o_.map_frame},
           {"child_frame_id", o_.base_frame},
           {"translation", xyz(base_in_map.translation())},
           {"rotation", xyzw(base_in_map.linear())}}
          .dump());
}

void RunLog::scan(const ScanReport& r, const Scan& points, const std::vector<std::uint16_t>& rings, double total_ms) {
  const std::uint64_t ns = to_ns(r.t, writer_.path());
  ScanPrepConfig prep = o_.scan;
  prep.voxel_m = o_.scan_voxel_m;
  const Scan kept = prepare_scan(points, rings, prep);
  std::string packed;
  packed.reserve(kept.size() * kStride);
  for (const PointXYZI& p : kept) pack(packed, r.fused * Eigen::Vector3d(p.x, p.y, p.z));
  put(scan_, "/scan", r.t, cloud_json(ns, o_.map_frame, packed).dump());

  Json timing{{"prepare", r.prepare_ms}, {"map", r.map_ms}, {"register", r.register_ms}, {"odometry", r.odometry_ms},
              {"integrity", r.integrity_ms}};
  if (total_ms >= 0) timing["total"] = total_ms;
  const Json health{{"timestamp", stamp(ns)},
                    {"health", health_name(r.health)},
                    {"note", r.note},
                    {"protection_m", r.protection_m},
                    {"registration_sigma_m", r.registration_sigma_m},
                    {"position_sigma_m", r.position_sigma.norm()},
                    {"uncertainty_m", r.uncertainty.horizontal()},
                    {"fused", r.fused_lidar},
                    {"motion", r.motion ? r.motion : ""},
                    {"basin", basin_name(r.basin)},
                    {"map_outdated", r.map_outdated},
                    {"icp",
                     {{"iterations", r.icp.iterations},
                      {"converged", r.icp.converged},
                      {"accepted", r.icp.accepted},
                      {"pairs", r.icp.pairs},
                      {"fitness", r.icp.inlier_share},
                      {"rms_m", r.icp.rms_m},
                      {"conditioning", r.icp.conditioning},
                      {"reject_reason", r.icp.reject_reason ? r.icp.reject_reason : ""}}},
                    {"scan_points", r.scan_points},
                    {"map_tiles", r.map_tiles},
                    {"map_points", r.map_points},
                    {"timing_ms", timing}};
  put(health_, "/health", r.t, health.dump());
}

void RunLog::map(double t, const std::vector<MapTile>& tiles) {
  std::vector<std::pair<TileKey, std::string>> now;
  for (const MapTile& tile : tiles)
    if (tile.cloud) now.emplace_back(tile.key, tile.hash);
  std::sort(now.begin(), now.end());
  if (map_any_ && now == map_written_) return;
  std::string packed;
  for (const MapTile& tile : tiles)
    if (tile.cloud) packed += thinned_tile(*tile.cloud, o_.map_voxel_m);
  const std::uint64_t ns = to_ns(t, writer_.path());
  put(map_, "/map", t, cloud_json(ns, o_.map_frame, packed).dump());
  map_written_ = std::move(now);
  map_any_ = true;
}

void RunLog::gps(const GpsFix& fix) {
  if (fix.status == kGpsNone) return;  // no position
  const std::uint64_t ns = to_ns(fix.t, writer_.path());
  const double h = fix.std_m * fix.std_m;
  Json cov = Json::array();
  for (int i = 0; i < 9; ++i) cov.push_back(0.0);
  if (fix.std_m > 0) {
    cov[0] = h;
    cov[4] = h;
    cov[8] = 4.0 * h;
  }
  put(gps_, "/gps", fix.t,
      Json{{"timestamp", stamp(ns)},
           {"frame_id", "gps"},
           {"latitude", fix.position.lat_deg},
           {"longitude", fix.position.lon_deg},
           {"altitude", fix.position.alt_m},
           {"position_covariance", cov},
           {"position_covariance_type", fix.std_m > 0 ? 1 : 0}}  // APPROXIMATED: the vertical is a guess
          .dump());
}

void RunLog::close() { writer_.close(); }

}  // namespace pl::client

#include "pl/maps/drive_record.hpp"

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <fstream>
#include <iterator>

#include <nlohmann/json.hpp>

#include "pl/common/error.hpp"
#include "pl/common/output_path.hpp"
#include "pl/common/text.hpp"

namespace pl::maps {

namespace {

constexpr const char* kFormat = "pointlocalization map drives";
constexpr int kVersion = 1;

// nlohmann writes doubles in the shortest form that reads back to the same bits: the poses come back
// exactly, which the merge needs to give the same voxels.
nlohmann::json pose_json(const Pose& p) {
  nlohmann::json row = nlohmann::json::array();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) row.push_back(p.matrix()(r, c));
  return row;
}

double finite(const nlohmann::json& v, const std::string& what) {
  if (!v.is_number()) throw Error(what + " is not a number");
  const double x = v.get<double>();
  if (!std::isfinite(x)) throw Error(what + " is not finite");
  return x;
}

Pose pose_of(const nlohmann::json& row, const std::string& what) {
  if (!row.is_array() || row.size() != 12) throw Error(what + " is not 12 numbers (a 3x4 matrix, row by row)");
  Pose p = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) p.matrix()(r, c) = finite(row[static_cast<std::size_t>(4 * r + c)], what);
  if (!(std::abs(p.linear().determinant() - 1.0) < 1e-3)) throw Error(what + " has no rotation (its determinant is not 1)");
  return p;
}

const nlohmann::json& field(const nlohmann::json& o, const char* name, const std::string& where) {
  const auto it = o.find(name);
  if (it == o.end()) throw Error(where + " has no \"" + name + "\"");
  return *it;
}

}  // namespace

std::string drive_record_path(const std::string& map) { return beside(map, ".drives.json"); }

std::string encode_drive_record(const DriveRecord& record) {
  const MapBuildConfig& m = record.merge;
  nlohmann::json j;
  j["format"] = kFormat;
  j["version"] = kVersion;
  j["origin"] = record.origin ? nlohmann::json{{"lat", record.origin->lat_deg}, {"lon", record.origin->lon_deg}, {"alt", record.origin->alt_m}}
                              : nlohmann::json(nullptr);
  j["merge"] = {{"voxel_m", m.voxel_m},
                {"first", m.first},
                {"last", m.last == SIZE_MAX ? nlohmann::json(nullptr) : nlohmann::json(m.last)},
                {"every", m.every},
                {"beams", m.scan.beams},
                {"fov_deg", m.scan.fov_deg},
                {"min_range_m", m.scan.min_range_m},
                {"max_range_m", m.scan.max_range_m}};
  j["drives"] = nlohmann::json::array();
  for (const RecordedDrive& d : record.drives) {
    nlohmann::json poses = nlohmann::json::array();
    for (const Pose& p : d.poses.poses) poses.push_back(pose_json(p));
    j["drives"].push_back({{"dataset", d.dataset}, {"deskew", d.deskew}, {"sweep_s", d.sweep_s}, {"times", d.poses.times}, {"poses", poses}});
  }
  return j.dump() + "\n";
}

DriveRecord decode_drive_record(const std::string& bytes, const std::string& source) {
  const nlohmann::json j = nlohmann::json::parse(bytes, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw Error(source + ": not a drive record (JSON, as pl-map build writes beside its map)");
  try {
    if (j.value("format", std::string()) != kFormat) throw Error("its \"format\" is not \"" + std::string(kFormat) + "\"");
    const nlohmann::json& version = field(j, "version", "the record");
    if (!version.is_number_integer() || version.get<std::int64_t>() != kVersion)
      throw Error("version " + version.dump() + " is not one this build reads (1); build the base map again with this pl-map");
    DriveRecord r;
    const nlohmann::json& origin = field(j, "origin", "the record");
    if (!origin.is_null()) {
      if (!origin.is_object()) throw Error("its origin is not {lat, lon, alt}");
      r.origin = GeoPoint{finite(field(origin, "lat", "its origin"), "the origin's lat"),
                          finite(field(origin, "lon", "its origin"), "the origin's lon"),
                          finite(field(origin, "alt", "its origin"), "the origin's alt")};
      if (std::abs(r.origin->lat_deg) > 90 || std::abs(r.origin->lon_deg) > 180) throw Error("its origin is not a place on Earth");
    }
    const nlohmann::json& m = field(j, "merge", "the record");
    if (!m.is_object()) throw Error("its \"merge\" is not an object");
    auto count = [&](const char* name, std::size_t lo) {
      const nlohmann::json& v = field(m, name, "its merge");
      if (!v.is_number_unsigned() || v.get<std::uint64_t>() < lo) throw Error(format_text("its merge's %s is not a count of at least %zu", name, lo));
      return static_cast<std::size_t>(v.get<std::uint64_t>());
    };
    r.merge.voxel_m = finite(field(m, "voxel_m", "its merge"), "its merge's voxel_m");
    if (!(r.merge.voxel_m >= 0.01 && r.merge.voxel_m <= 10)) throw Error("its merge's voxel_m is not within 0.01..10 m");
    r.merge.first = count("first", 0);
    r.merge.last = field(m, "last", "its merge").is_null() ? SIZE_MAX : count("last", 0);
    r.merge.every = count("every", 1);
    r.merge.scan.beams = static_cast<int>(count("beams", 0));
    if (r.merge.scan.beams > 1024) throw Error("its merge's beams is above 1024");
    r.merge.scan.fov_deg = finite(field(m, "fov_deg", "its merge"), "its merge's fov_deg");
    r.merge.scan.min_range_m = finite(field(m, "min_range_m", "its merge"), "its merge's min_range_m");
    r.merge.scan.max_range_m = finite(field(m, "max_range_m", "its merge"), "its merge's max_range_m");
    if (!(r.merge.scan.fov_deg > 0 && r.merge.scan.fov_deg <= 360) || !(r.merge.scan.min_range_m >= 0) ||
        !(r.merge.scan.max_range_m > r.merge.scan.min_range_m))
      throw Error("its merge's crops are out of range (0 < fov_deg <= 360, 0 <= min_range_m < max_range_m)");
    const nlohmann::json& drives = field(j, "drives", "the record");
    if (!drives.is_array() || drives.empty() || drives.size() > 64) throw Error("its \"drives\" is not a list of 1 to 64 drives");
    for (std::size_t d = 0; d < drives.size(); ++d) {
      const std::string where = format_text("drive %zu", d + 1);
      const nlohmann::json& dj = drives[d];
      if (!dj.is_object()) throw Error(where + " is not an object");
      RecordedDrive rd;
      const nlohmann::json& dataset = field(dj, "dataset", where);
      if (!dataset.is_string() || dataset.get<std::string>().empty()) throw Error(where + "'s dataset is not a path");
      rd.dataset = dataset.get<std::string>();
      const nlohmann::json& deskew = field(dj, "deskew", where);
      if (!deskew.is_boolean()) throw Error(where + "'s deskew is not true or false");
      rd.deskew = deskew.get<bool>();
      rd.sweep_s = finite(field(dj, "sweep_s", where), where + "'s sweep_s");
      if (!(rd.sweep_s > 0 && rd.sweep_s <= 10)) throw Error(where + "'s sweep_s is not within (0, 10] s");
      const nlohmann::json& poses = field(dj, "poses", where);
      const nlohmann::json& times = field(dj, "times", where);
      if (!poses.is_array() || poses.empty()) throw Error(where + " has no poses");
      if (!times.is_array() || times.size() != poses.size())
        throw Error(format_text("%s has %zu times for %zu poses", where.c_str(), times.is_array() ? times.size() : 0, poses.size()));
      for (std::size_t i = 0; i < poses.size(); ++i) {
        rd.poses.poses.push_back(pose_of(poses[i], format_text("%s's pose %zu", where.c_str(), i + 1)));
        rd.poses.times.push_back(finite(times[i], format_text("%s's time %zu", where.c_str(), i + 1)));
      }
      r.drives.push_back(std::move(rd));
    }
    return r;
  } catch (const nlohmann::json::exception& e) {
    throw Error(source + ": not a drive record (" + e.what() + ")");
  } catch (const Error& e) {
    throw Error(source + ": " + e.what());
  }
}

void write_drive_record(const std::string& path, const DriveRecord& record) {
  const std::string bytes = encode_drive_record(record), partial = path + ".partial";
  {
    std::ofstream f(partial, std::ios::binary | std::ios::trunc);
    f.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    if (!f) throw Error(partial + ": cannot write the map's drive record");
  }
  if (std::rename(partial.c_str(), path.c_str()) != 0) throw Error(path + ": cannot write the map's drive record (rename failed)");
}

DriveRecord read_drive_record(const std::string& path) {
  std::ifstream f(path, std::ios::binary);
  if (!f)
    throw Error(path + ": cannot read it: a base map needs the record of its drives that pl-map build writes beside it "
                "(MAP.drives.json); build the base map again with this pl-map");
  const std::string bytes((std::istreambuf_iterator<char>(f)), std::istreambuf_iterator<char>());
  return decode_drive_record(bytes, path);
}

void check_same_merge(const DriveRecord& record, const MapBuildConfig& merge, const std::string& source) {
  const MapBuildConfig& b = record.merge;
  // what: an option ("--voxel") or a setting without one ("the beams kept"); the fix names the option.
  auto differs = [&](bool same, const std::string& what, const std::string& base, const std::string& now) {
    if (same) return;
    const bool option = what.rfind("--", 0) == 0;
    throw Error(source + " was merged with " + what + " " + base + ", this build with " + now + ": " +
                (option ? "give " + what + " " + base + " so that its tiles keep their points, or build" : "build") +
                " the whole map anew without --base-map");
  };
  auto num = [](double v) { return format_text("%g", v); };
  auto range = [](const MapBuildConfig& m) {
    return std::to_string(m.first) + ".." + (m.last == SIZE_MAX ? std::string("the last") : std::to_string(m.last));
  };
  differs(merge.voxel_m == b.voxel_m, "--voxel", num(b.voxel_m), num(merge.voxel_m));
  differs(merge.every == b.every, "--every", std::to_string(b.every), std::to_string(merge.every));
  differs(merge.scan.min_range_m == b.scan.min_range_m, "--min-range", num(b.scan.min_range_m), num(merge.scan.min_range_m));
  differs(merge.scan.max_range_m == b.scan.max_range_m, "--max-range", num(b.scan.max_range_m), num(merge.scan.max_range_m));
  differs(merge.first == b.first && merge.last == b.last, "scans", range(b), range(merge));
  differs(merge.scan.beams == b.scan.beams, "beams kept", std::to_string(b.scan.beams), std::to_string(merge.scan.beams));
  differs(merge.scan.fov_deg == b.scan.fov_deg, "a field of view of", num(b.scan.fov_deg), num(merge.scan.fov_deg));
}

}  // namespace pl::maps

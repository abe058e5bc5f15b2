// Fuzz target: a drive folder as open_dataset reads it, through the real reader on real files.
//
// The input is a list of files, each a line "@@ RELATIVE/PATH" followed by its content up to the
// next line that starts with "@@ " (the newline before that line ends the separator, not the
// content):
//
//   @@ velodyne/000000.bin
//   <32 bytes: two points>
//   @@ times.txt
//   0
//
// The paths choose the layout (velodyne/ for KITTI odometry; velodyne_points/data/ and oxts/data/
// for KITTI raw) and the sidecars. The files go into a fresh folder per input (in /dev/shm when
// there is one: no disk writes at thousands of inputs a second), removed afterwards. Then every
// scan is loaded and given its rings, as the localizer does.
//
// Refusing with pl::Error is fine; a dataset that opens must be consistent: one time (finite) per
// scan in frame order, poses one per scan or none and finite, GPS fixes within range, a meta the
// reader's own rules allow.
#include <signal.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <string_view>
#include <system_error>
#include <utility>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/recordings/dataset.hpp"

namespace fs = std::filesystem;

namespace {

constexpr std::size_t kMaxFiles = 64;
constexpr std::size_t kMaxPathLength = 96;

// A path inside the dataset folder: relative, at most four parts of [A-Za-z0-9._-], no "." or "..".
bool safe_relative_path(std::string_view p) {
  if (p.empty() || p.size() > kMaxPathLength) return false;
  std::size_t parts = 0, start = 0;
  while (start <= p.size()) {
    std::size_t end = p.find('/', start);
    if (end == std::string_view::npos) end = p.size();
    const std::string_view part = p.substr(start, end - start);
    if (part.empty() || part == "." || part == "..") return false;
    for (char c : part)
      if (!(std::isalnum(static_cast<unsigned char>(c)) || c == '.' || c == '_' || c == '-')) return false;
    if (++parts > 4) return false;
    start = end + 1;
  }
  return true;
}

// Splits the input into (path, content) pairs; false when a path is not one we may write.
bool split_files(std::string_view in, std::vector<std::pair<std::string, std::string_view>>& files) {
  static constexpr std::string_view kMark = "@@ ";
  if (in.substr(0, kMark.size()) != kMark) return false;
  std::size_t pos = 0;
  while (pos < in.size()) {
    const std::size_t name_start = pos + kMark.size();
    std::size_t name_end = in.find('\n', name_start);
    if (name_end == std::string_view::npos) name_end = in.size();
    std::string_view name = in.substr(name_start, name_end - name_start);
    if (!name.empty() && name.back() == '\r') name.remove_suffix(1);
    if (!safe_relative_path(name) || files.size() == kMaxFiles) return false;
    const std::size_t body = std::min(name_end + 1, in.size());
    // From the header's own newline: a file whose content is empty is followed at once by "@@ ".
    const std::size_t next = in.find("\n@@ ", name_end);
    const std::size_t body_end = next == std::string_view::npos ? in.size() : std::max(next, body);
    files.emplace_back(std::string(name), in.substr(body, body_end - body));
    pos = next == std::string_view::npos ? in.size() : next + 1;
  }
  return true;
}

// Never destroyed: remove_base_dir() runs at exit, after the static objects made after its
// registration are gone.
const std::string& base_dir() {
  static const std::string* dir = [] {
    const fs::path root = fs::is_directory("/dev/shm") ? fs::path("/dev/shm") : fs::temp_directory_path();
    return new std::string((root / ("pl-fuzz-dataset-" + std::to_string(::getpid()))).string());
  }();
  return *dir;
}

// The folder of one input, removed on every way out.
class RunDir {
 public:
  RunDir() : path_(base_dir() + "/drive") { clear(); }
  ~RunDir() { clear(); }
  const std::string& path() const { return path_; }
  // False when the file cannot be written (a path that is also a file's folder, ...).
  bool write(const std::string& rel, std::string_view bytes) const {
    const fs::path p = fs::path(path_) / rel;
    std::error_code ec;
    fs::create_directories(p.parent_path(), ec);
    if (ec || fs::exists(p, ec)) return false;
    std::ofstream out(p, std::ios::binary);
    out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
    return static_cast<bool>(out);
  }

 private:
  void clear() const {
    std::error_code ec;
    fs::remove_all(path_, ec);
  }
  std::string path_;
};

void remove_base_dir() {
  std::error_code ec;
  fs::remove_all(base_dir(), ec);
}

// The folders of earlier runs that did not exit (a crash, a timeout, a fork-mode job killed):
// removed when their process is gone, so that long runs do not fill /dev/shm.
void remove_stale_base_dirs() {
  static constexpr std::string_view kPrefix = "pl-fuzz-dataset-";
  std::error_code ec, ignored;
  // The non-throwing increment: other processes add and remove entries of /dev/shm meanwhile.
  for (fs::directory_iterator it(fs::path(base_dir()).parent_path(), ec), end; !ec && it != end; it.increment(ec)) {
    const std::string name = it->path().filename().string();
    if (name.rfind(kPrefix, 0) != 0) continue;
    const long pid = std::strtol(name.c_str() + kPrefix.size(), nullptr, 10);
    if (pid > 0 && ::kill(static_cast<pid_t>(pid), 0) != 0 && errno == ESRCH) fs::remove_all(it->path(), ignored);
  }
}

bool finite_pose(const pl::Pose& p) { return p.matrix().allFinite(); }

void check_dataset(const pl::Dataset& ds) {
  const std::size_t n = ds.size();
  if (n == 0 || ds.frame_ids.size() != n || ds.times.size() != n) std::abort();
  for (std::size_t i = 0; i < n; ++i) {
    if (ds.frame_ids[i] < 0 || (i > 0 && ds.frame_ids[i] <= ds.frame_ids[i - 1])) std::abort();
    if (!std::isfinite(ds.times[i])) std::abort();
  }
  if (ds.has_ground_truth()) {
    if (ds.ground_truth.poses.size() != n || ds.ground_truth.times != ds.times) std::abort();
    for (const auto& p : ds.ground_truth.poses)
      if (!finite_pose(p)) std::abort();
  }
  for (const auto& g : ds.gps) {
    if (!std::isfinite(g.t) || !(std::abs(g.position.lat_deg) <= 90) || !(std::abs(g.position.lon_deg) <= 180) ||
        !std::isfinite(g.position.alt_m) || !(g.std_m >= 0) || !std::isfinite(g.std_m) || g.status < pl::kGpsNone ||
        g.status > pl::kGpsFixed)
      std::abort();
  }
  for (std::size_t i = 0; i < ds.encoder.size(); ++i) {
    const auto& e = ds.encoder[i];
    if (!std::isfinite(e.t) || !std::isfinite(e.left_m) || !std::isfinite(e.right_m)) std::abort();
    if (i > 0 && e.t < ds.encoder[i - 1].t) std::abort();
  }
  if (!ds.encoder.empty() && !(ds.meta.vehicle.wheel_base_m > 0)) std::abort();
  for (const auto& o : ds.odometry) {
    if (!std::isfinite(o.t) || !finite_pose(o.pose)) std::abort();
    if (std::abs(o.pose.linear().determinant() - 1.0) > 1e-6) std::abort();
  }
  const auto& s = ds.meta.sensor;
  if (s.beams < 1 || s.beams > 1024) std::abort();
  if (!s.vertical_angles_deg.empty() && s.vertical_angles_deg.size() != static_cast<std::size_t>(s.beams)) std::abort();
  if (s.point_order != "laser-by-laser" && s.point_order != "any") std::abort();
  if (ds.meta.origin && !(std::abs(ds.meta.origin->lat_deg) <= 90 && std::abs(ds.meta.origin->lon_deg) <= 180)) std::abort();
  if (ds.projection.kind == pl::WorldProjection::Kind::KittiMercator &&
      (!finite_pose(ds.projection.world_from_projected) || !std::isfinite(ds.projection.mercator_scale)))
    std::abort();
}

// What a tool does next with an opened drive: every scan, its rings, a GPS fix in the world frame.
void use_dataset(const pl::Dataset& ds) {
  for (std::size_t i = 0; i < ds.size(); ++i) {
    try {
      const pl::Scan scan = ds.load_scan(i);
      if (ds.rings(scan).size() != scan.size()) std::abort();
    } catch (const pl::Error&) {
    }
  }
  if (!ds.gps.empty()) {
    try {
      (void)ds.to_world(ds.gps.front().position);
    } catch (const pl::Error&) {
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  remove_stale_base_dirs();
  std::atexit(remove_base_dir);
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  std::vector<std::pair<std::string, std::string_view>> files;
  if (!split_files(std::string_view(reinterpret_cast<const char*>(data), size), files)) return 0;
  const RunDir dir;
  for (const auto& [name, bytes] : files)
    if (!dir.write(name, bytes)) return 0;
  pl::Dataset ds;
  try {
    ds = pl::open_dataset(dir.path());
  } catch (const pl::Error&) {
    return 0;
  }
  check_dataset(ds);
  use_dataset(ds);
  return 0;
}

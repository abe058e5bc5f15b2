// The map viewer's side of pl-server (see viewer.hpp):
//   GET  /viewer/, /viewer/FILE                 the viewer's static files (viewer/, built into BUILD/viewer)
//   GET  /v1/maps/{map}/versions                the versions, with state, date and note
//   GET  /v1/maps/{map}/versions/{v}/overview   the version thinned to one point per 2 m voxel
//   POST /v1/maps/{map}/vehicles/{id}           a vehicle's position and health (report role)
//   GET  /v1/maps/{map}/vehicles                the vehicles heard from lately
//   GET  /v1/maps/{map}/events                  their updates as Server-Sent Events
#include "viewer.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <deque>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <unordered_map>
#include <utility>
#include <vector>

#include "api_parts.hpp"
#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/change_report.hpp"

// Where the build assembles the viewer, and where `cmake --install` puts it under the prefix
// (server/CMakeLists.txt sets both).
#ifndef PL_VIEWER_BUILD_DIR
#define PL_VIEWER_BUILD_DIR ""
#endif
#ifndef PL_VIEWER_INSTALL_SUBDIR
#define PL_VIEWER_INSTALL_SUBDIR "share/pointlocalization/viewer"
#endif

namespace pl::server {

using namespace api_parts;
namespace fs = std::filesystem;

std::string default_viewer_dir() {
  // An installed pl-server (PREFIX/bin) serves the viewer installed beside it (PREFIX/share/...),
  // wherever the prefix was moved; one in the build tree the build's.
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) {
    const fs::path installed = exe.parent_path().parent_path() / PL_VIEWER_INSTALL_SUBDIR;
    if (fs::is_regular_file(installed / "index.html", ec)) return installed.string();
  }
  return PL_VIEWER_BUILD_DIR;
}

// ---------------------------------------------------------------------------------------------
// EventStream

void EventStream::set_wake(std::function<void()> wake) {
  std::lock_guard<std::mutex> lock(mutex_);
  wake_ = std::move(wake);
}

bool EventStream::push(std::string_view record) {
  std::function<void()> wake;
  bool ok = false;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return false;
    if (pending_.size() + record.size() > kMaxPendingBytes) {
      closed_ = true;  // the client does not read: the connection ends, it may connect again
      pending_.clear();
    } else {
      pending_.append(record);
      ok = true;
    }
    wake = wake_;
  }
  if (wake) wake();  // outside the lock: it posts to the connection's strand
  return ok;
}

std::string EventStream::take() {
  std::lock_guard<std::mutex> lock(mutex_);
  return std::exchange(pending_, {});
}

void EventStream::close() {
  std::function<void()> wake;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (closed_) return;
    closed_ = true;
    wake = wake_;
  }
  if (wake) wake();
}

bool EventStream::closed() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return closed_;
}

namespace {

// ---------------------------------------------------------------------------------------------
// Static files

// The types browsers insist on: module scripts must be JavaScript, WebAssembly.instantiateStreaming
// wants application/wasm; nosniff (below) keeps them from guessing otherwise.
std::string content_type_of(const std::string& name) {
  const auto dot = name.rfind('.');
  const std::string ext = dot == std::string::npos ? "" : name.substr(dot + 1);
  if (ext == "html") return "text/html; charset=utf-8";
  if (ext == "js" || ext == "mjs") return "text/javascript; charset=utf-8";
  if (ext == "css") return "text/css; charset=utf-8";
  if (ext == "json") return "application/json";
  if (ext == "wasm") return "application/wasm";
  if (ext == "png") return "image/png";
  if (ext == "svg") return "image/svg+xml";
  if (ext == "txt" || ext == "md") return "text/plain; charset=utf-8";
  return "application/octet-stream";
}

// A path segment the viewer's folder can hold: letters, digits, '.', '_', '-', not starting with a
// dot. Checked after percent-decoding, so "..", "%2e%2e", "..%2f.." and "%00" are all refused, and
// so are hidden files.
bool valid_segment(const std::string& s) {
  if (s.empty() || s.front() == '.') return false;
  return std::all_of(s.begin(), s.end(), [](unsigned char c) { return std::isalnum(c) || c == '.' || c == '_' || c == '-'; });
}

struct StaticFile {
  std::int64_t mtime_ns = 0;
  std::int64_t size = -1;
  std::shared_ptr<const std::string> bytes;
  std::string hash;
};

// ---------------------------------------------------------------------------------------------
// The overview level

// One point per 2 m voxel: the overview replaces the tiles once the view is wider than a few hundred
// metres (viewer/src/js/main.mjs), where a pixel of a 1,280-pixel canvas covers 0.5 m or more, so a
// 2 m voxel is 2 to 4 pixels apart: the map's shape, streets, facades and trees still read, while
// surfaces keep (0.2 m / 2 m)^2 = 1 % of the map's 0.2 m voxels (the town loop: 1.75 M points in 201
// tiles, 7.3 MB, give an overview of about 1 % of the points and bytes; docs/viewer.md). A version
// larger than kOverviewMaxPoints at 2 m is thinned at 4, 8, ... m until it fits, so that a browser
// can always draw it.
constexpr double kOverviewVoxelM = 2.0;
constexpr std::size_t kOverviewMaxPoints = 500'000;
constexpr std::size_t kOverviewsKept = 8;  // versions whose overview is kept in memory

struct Overview {
  std::shared_ptr<const std::string> bytes;
  std::string hash;
  double voxel = kOverviewVoxelM;
  std::size_t points = 0;
};

struct CellKey {
  std::int64_t x, y, z;
  bool operator==(const CellKey& o) const { return x == o.x && y == o.y && z == o.z; }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const {
    // Unsigned: the products wrap (a tile far out, say) instead of overflowing.
    return static_cast<std::size_t>(static_cast<std::uint64_t>(k.x) * 73856093u ^ static_cast<std::uint64_t>(k.y) * 19349663u ^
                                    static_cast<std::uint64_t>(k.z) * 83492791u);
  }
};
struct Cell {
  double x = 0, y = 0, z = 0, intensity = 0;
  std::uint64_t n = 0;
};
using Cells = std::unordered_map<CellKey, Cell, CellHash>;

CellKey key_of(double x, double y, double z, double voxel) {
  return {static_cast<std::int64_t>(std::floor(x / voxel)), static_cast<std::int64_t>(std::floor(y / voxel)),
          static_cast<std::int64_t>(std::floor(z / voxel))};
}

// The cells regrouped at twice the voxel: sums add, so the centroids stay the exact means of the
// tiles' points.
Cells coarser(const Cells& cells, double voxel) {
  Cells out;
  out.reserve(cells.size() / 4);
  for (const auto& [k, c] : cells) {
    const double n = static_cast<double>(c.n);
    Cell& to = out[key_of(c.x / n, c.y / n, c.z / n, voxel)];
    to.x += c.x, to.y += c.y, to.z += c.z, to.intensity += c.intensity, to.n += c.n;
  }
  return out;
}

Overview make_overview(store::Store& db, const std::string& map, std::int64_t version) {
  Overview o;
  Cells cells;
  bool intensity = true;  // only when every tile has it
  for (const auto& t : db.list_tiles(map, version)) {
    const auto bytes = db.blob(t.hash);
    if (!bytes) throw Error("map " + map + " version " + std::to_string(version) + ": tile blob " + t.hash + " is missing from the store");
    const TileCloud c = decode_tile(*bytes);
    intensity = intensity && c.intensity.size() == c.size();
    for (std::size_t i = 0; i < c.size(); ++i) {
      const auto& p = c.points[i];
      Cell& cell = cells[key_of(p.x(), p.y(), p.z(), o.voxel)];
      cell.x += p.x(), cell.y += p.y(), cell.z += p.z(), ++cell.n;
      if (!c.intensity.empty()) cell.intensity += c.intensity[i];
    }
    // Memory stays bounded however large the version: coarser as soon as it cannot fit anyway.
    while (cells.size() > 4 * kOverviewMaxPoints) cells = coarser(cells, o.voxel *= 2);
  }
  while (cells.size() > kOverviewMaxPoints) cells = coarser(cells, o.voxel *= 2);
  TileCloud out;
  out.points.reserve(cells.size());
  for (const auto& [k, c] : cells) {
    const double n = static_cast<double>(c.n);
    out.points.emplace_back(c.x / n, c.y / n, c.z / n);
    if (intensity) out.intensity.push_back(static_cast<float>(c.intensity / n));
  }
  TileCodecConfig cfg;
  cfg.max_error_m = 0.01 * o.voxel;  // 2 cm on 2 m voxels: invisible
  o.bytes = std::make_shared<const std::string>(encode_tile(out, cfg));
  o.hash = store::content_hash(*o.bytes);
  o.points = out.size();
  return o;
}

// ---------------------------------------------------------------------------------------------
// Live vehicles

struct Vehicle {
  double x = 0, y = 0, z = 0, yaw = 0;
  std::string health;
  std::optional<double> t;  // the vehicle's own time, as it sent it
  double received = 0;      // the server's time, seconds since 1970
  std::chrono::steady_clock::time_point seen;
};

double unix_now() { return std::chrono::duration<double>(std::chrono::system_clock::now().time_since_epoch()).count(); }

json vehicle_json(const std::string& id, const Vehicle& v, std::chrono::steady_clock::time_point now) {
  return {{"id", id},
          {"x", v.x},
          {"y", v.y},
          {"z", v.z},
          {"yaw", v.yaw},
          {"health", v.health},
          {"t", v.t ? json(*v.t) : json(nullptr)},
          {"received", std::round(v.received * 1000) / 1000},
          {"age_s", std::round(std::chrono::duration<double>(now - v.seen).count() * 1000) / 1000}};
}

// One Server-Sent Events record (https://html.spec.whatwg.org/multipage/server-sent-events.html):
// the data is one line of JSON, which never holds a newline.
std::string sse_record(const char* event, const json& data) {
  return std::string("event: ") + event + "\ndata: " + data.dump(-1, ' ', false, json::error_handler_t::replace) + "\n\n";
}

}  // namespace

// ---------------------------------------------------------------------------------------------

struct Viewer::Impl {
  std::string dir;  // the viewer's files; empty or missing: /viewer/ answers 404 saying how to build them
  std::size_t max_streams, max_vehicles;
  double vehicle_timeout_s;

  std::mutex files_mutex;
  std::unordered_map<std::string, StaticFile> files;  // by path under dir

  std::mutex overview_mutex;
  std::map<std::string, std::shared_ptr<const Overview>> overviews;  // "map id/created/version"
  std::deque<std::string> overview_order;
  std::set<std::string> overview_busy;  // being made by some thread now

  // The vehicles: all in memory, this process only (replicas do not share them), bounded by
  // max_vehicles over all maps, each dropped vehicle_timeout_s after it was last heard from.
  std::mutex hub_mutex;
  std::map<std::string, std::map<std::string, Vehicle>> vehicles;  // map -> id -> last report
  std::size_t vehicle_count = 0;
  std::map<std::string, std::vector<std::weak_ptr<EventStream>>> streams;  // map -> its subscribers

  explicit Impl(const ApiConfig& cfg)
      : dir(cfg.viewer_dir.empty() ? default_viewer_dir() : cfg.viewer_dir),
        max_streams(cfg.max_event_streams),
        max_vehicles(cfg.max_vehicles),
        vehicle_timeout_s(cfg.vehicle_timeout_s) {}

  // Under hub_mutex: a record to every open stream of the map; closed and finished ones are dropped.
  void broadcast(const std::string& map, const std::string& record) {
    auto it = streams.find(map);
    if (it == streams.end()) return;
    auto& list = it->second;
    list.erase(std::remove_if(list.begin(), list.end(),
                              [&](const std::weak_ptr<EventStream>& w) {
                                auto s = w.lock();
                                return !s || !s->push(record);
                              }),
               list.end());
  }

  // Under hub_mutex: drops the vehicles silent for longer than the timeout, telling their streams.
  void sweep(std::chrono::steady_clock::time_point now) {
    const auto timeout = std::chrono::duration<double>(vehicle_timeout_s);
    for (auto m = vehicles.begin(); m != vehicles.end();) {
      for (auto v = m->second.begin(); v != m->second.end();) {
        if (now - v->second.seen <= timeout) {
          ++v;
          continue;
        }
        broadcast(m->first, sse_record("gone", {{"id", v->first}}));
        v = m->second.erase(v);
        --vehicle_count;
      }
      m = m->second.empty() ? vehicles.erase(m) : std::next(m);
    }
  }

  // Under hub_mutex: the streams whose connection still holds them.
  std::size_t live_streams() {
    std::size_t n = 0;
    for (auto m = streams.begin(); m != streams.end();) {
      auto& list = m->second;
      list.erase(std::remove_if(list.begin(), list.end(),
                                [](const std::weak_ptr<EventStream>& w) {
                                  auto s = w.lock();
                                  return !s || s->closed();
                                }),
                 list.end());
      n += list.size();
      m = list.empty() ? streams.erase(m) : std::next(m);
    }
    return n;
  }
};

Viewer::Viewer(const ApiConfig& cfg) : impl_(std::make_unique<Impl>(cfg)) {}
Viewer::~Viewer() = default;

ApiResponse Viewer::file(const ApiRequest& req) {
  const std::string route = "/viewer/{file}";
  const auto q = req.target.find('?');
  const std::string path = req.target.substr(0, q);
  if (path == "/viewer") {  // the page's relative URLs (js/main.mjs) need the folder's slash
    ApiResponse r;
    r.status = 301;
    r.content_type = "text/plain; charset=utf-8";
    r.body = "the viewer is at /viewer/\n";
    r.headers = {{"Location", "/viewer/" + (q == std::string::npos ? "" : req.target.substr(q))}};
    r.route = route;
    return r;
  }
  if (path.rfind("/viewer/", 0) != 0) fail(404, "no such resource: " + req.target + " (the viewer is at /viewer/)");
  std::string rest = path.substr(8);
  if (rest.empty()) rest = "index.html";
  std::string relative;
  for (std::size_t i = 0;;) {
    const std::size_t j = rest.find('/', i);
    const std::string segment = url_decode(rest.substr(i, j == std::string::npos ? std::string::npos : j - i));
    if (!valid_segment(segment))
      fail(400, "\"" + path + "\" is not a file of the viewer: its names are letters, digits, '.', '_' and '-', not starting with "
                "'.', and the viewer serves its own folder only (no \"..\")");
    relative += (relative.empty() ? "" : "/") + segment;
    if (j == std::string::npos) break;
    i = j + 1;
  }
  const std::string& dir = impl_->dir;
  std::error_code ec;
  if (dir.empty() || !fs::is_regular_file(fs::path(dir) / "index.html", ec))
    fail(404, "the viewer's files are not in " + (dir.empty() ? std::string("this build") : dir) +
                  ": build them (cmake --build BUILD_DIR --target viewer) or start pl-server with --viewer-dir DIR");
  const std::string full = dir + "/" + relative;
  struct stat st {};
  if (::stat(full.c_str(), &st) != 0 || !S_ISREG(st.st_mode)) fail(404, "the viewer has no file " + relative);
  // A link inside the folder may point out of it: only what resolves inside is served.
  const fs::path real = fs::canonical(full, ec), root = fs::canonical(dir, ec);
  const std::string real_s = real.string(), root_s = root.string() + "/";
  if (ec || real_s.compare(0, root_s.size(), root_s) != 0) fail(404, "the viewer has no file " + relative);

  const std::int64_t mtime_ns = static_cast<std::int64_t>(st.st_mtim.tv_sec) * 1'000'000'000 + st.st_mtim.tv_nsec;
  StaticFile f;
  {
    std::lock_guard<std::mutex> lock(impl_->files_mutex);
    auto it = impl_->files.find(relative);
    if (it != impl_->files.end()) f = it->second;
  }
  // Read again when it changed on disk (a rebuilt viewer shows without a restart).
  if (!f.bytes || f.mtime_ns != mtime_ns || f.size != static_cast<std::int64_t>(st.st_size)) {
    std::ifstream in(full, std::ios::binary);
    std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    if (!in && !in.eof()) fail(404, "the viewer's file " + relative + " cannot be read");
    f.mtime_ns = mtime_ns;
    f.size = static_cast<std::int64_t>(st.st_size);
    f.hash = store::content_hash(bytes);
    f.bytes = std::make_shared<const std::string>(std::move(bytes));
    std::lock_guard<std::mutex> lock(impl_->files_mutex);
    impl_->files[relative] = f;
  }
  ApiResponse r;
  r.route = route;
  const std::string etag = "\"" + f.hash + "\"";
  // The files' names do not change with their content: a browser keeps them but asks each time
  // whether they changed (304 when not), so an upgraded server's viewer is never mixed with an old one.
  r.headers = {{"ETag", etag}, {"Cache-Control", "no-cache"}, {"X-Content-Type-Options", "nosniff"}};
  if (!req.if_none_match.empty() && (req.if_none_match == "*" || req.if_none_match.find(etag) != std::string::npos)) {
    r.status = 304;
    r.content_type.clear();
    return r;
  }
  r.content_type = content_type_of(relative);
  r.blob = f.bytes;
  r.blob_hash = f.hash;
  return r;
}

ApiResponse Viewer::versions(store::Store& db, const store::MapInfo& m, bool staged_visible) {
  json list = json::array();
  for (const auto& v : db.list_versions(m.name)) {
    if (v.state == store::VersionState::Staged && !staged_visible) continue;
    list.push_back({{"version", v.number},
                    {"parent", v.parent ? json(*v.parent) : json(nullptr)},
                    {"state", store::state_name(v.state)},
                    {"created", v.created},
                    {"note", v.note},
                    {"tiles", v.tiles},
                    {"points", v.points},
                    {"bytes", v.bytes},
                    {"signed", db.signature(m.name, v.number).has_value()}});
  }
  return revalidated(json_response(
      200, {{"map", m.name}, {"current_version", m.current ? json(*m.current) : json(nullptr)}, {"versions", list}},
      "/v1/maps/{map}/versions"));
}

ApiResponse Viewer::overview(store::Store& db, const ApiRequest& req, const store::MapInfo& m, const store::VersionInfo& v) {
  // A published or retired version never changes: its overview is made once and kept. The key
  // names the map by id and creation time too (a map made again under its name is another map).
  const bool fixed = v.state != store::VersionState::Staged;
  const std::string key = std::to_string(m.id) + "/" + m.created + "/" + std::to_string(v.number);
  std::shared_ptr<const Overview> o;
  if (fixed) {
    std::lock_guard<std::mutex> lock(impl_->overview_mutex);
    auto it = impl_->overviews.find(key);
    if (it != impl_->overviews.end()) o = it->second;
    // Another request is making it: this one does not hold a second server thread meanwhile.
    else if (impl_->overview_busy.count(key))
      throw HttpError{503, "the overview of map " + m.name + " version " + std::to_string(v.number) + " is being made: retry in a second",
                      {{"Retry-After", "1"}}};
    else
      impl_->overview_busy.insert(key);
  }
  if (!o) {
    try {
      o = std::make_shared<const Overview>(make_overview(db, m.name, v.number));
    } catch (...) {
      std::lock_guard<std::mutex> lock(impl_->overview_mutex);
      impl_->overview_busy.erase(key);
      throw;
    }
    if (fixed) {
      std::lock_guard<std::mutex> lock(impl_->overview_mutex);
      impl_->overview_busy.erase(key);
      impl_->overviews[key] = o;
      impl_->overview_order.push_back(key);
      while (impl_->overview_order.size() > kOverviewsKept) {
        impl_->overviews.erase(impl_->overview_order.front());
        impl_->overview_order.pop_front();
      }
    }
  }
  ApiResponse r;
  r.route = "/v1/maps/{map}/versions/{v}/overview";
  const std::string etag = "\"" + o->hash + "\"";
  char voxel[32];
  std::snprintf(voxel, sizeof voxel, "%g", o->voxel);
  r.headers = {{"ETag", etag},
               {"Cache-Control", fixed ? "public, max-age=31536000, immutable" : "private, no-cache"},
               {"X-Overview-Voxel", voxel},
               {"X-Overview-Points", std::to_string(o->points)}};
  if (!req.if_none_match.empty() && (req.if_none_match == "*" || req.if_none_match.find(etag) != std::string::npos)) {
    r.status = 304;
    r.content_type.clear();
    return r;
  }
  r.content_type = "application/vnd.google.draco";
  r.blob = o->bytes;
  r.blob_hash = o->hash;
  return r;
}

ApiResponse Viewer::post_vehicle(const ApiRequest& req, const std::string& map, const std::string& id) {
  const std::string route = "/v1/maps/{map}/vehicles/{id}";
  if (!schema::valid_id(id)) fail(400, "a vehicle id is 1 to 128 letters, digits, '_', '.', ':' or '-' (as in its change reports), got \"" + id + "\"");
  const char* expected = "expected JSON {\"x\": m, \"y\": m, \"z\": m, \"yaw\": rad, \"health\": \"ok\"|\"degraded\"|\"lost\", \"t\": s} "
                         "(x, y in the map's ENU frame; z, yaw and t optional)";
  const json j = json::parse(req.body, nullptr, false);
  if (!j.is_object()) fail(400, std::string(expected) + ": the body is not a JSON object");
  auto number = [&](const char* name, bool required) -> std::optional<double> {
    if (!j.contains(name) || j[name].is_null()) {
      if (required) fail(400, std::string(expected) + ": \"" + name + "\" is missing");
      return std::nullopt;
    }
    if (!j[name].is_number()) fail(400, std::string(expected) + ": \"" + name + "\" must be a number");
    const double value = j[name].get<double>();
    if (!std::isfinite(value) || std::abs(value) > 1e10) fail(400, std::string(expected) + ": \"" + name + "\" is out of range");
    return value;
  };
  Vehicle v;
  v.x = *number("x", true);
  v.y = *number("y", true);
  v.z = number("z", false).value_or(0.0);
  v.yaw = number("yaw", false).value_or(0.0);
  v.t = number("t", false);
  if (!j.contains("health") || !j["health"].is_string()) fail(400, std::string(expected) + ": \"health\" is missing");
  v.health = j["health"].get<std::string>();
  if (v.health != "ok" && v.health != "degraded" && v.health != "lost")
    fail(400, "\"health\" is \"ok\", \"degraded\" or \"lost\", got \"" + v.health + "\"");
  const auto now = std::chrono::steady_clock::now();
  v.seen = now;
  v.received = unix_now();

  Impl& h = *impl_;
  std::lock_guard<std::mutex> lock(h.hub_mutex);
  h.sweep(now);
  auto& of_map = h.vehicles[map];
  const bool known = of_map.count(id) > 0;
  if (!known && h.vehicle_count >= h.max_vehicles) {
    if (of_map.empty()) h.vehicles.erase(map);
    const std::string after = std::to_string(static_cast<long>(std::ceil(h.vehicle_timeout_s)));
    throw HttpError{503,
                    "this server keeps " + std::to_string(h.max_vehicles) + " vehicles at most (pl-server --vehicles), and each for " + after +
                        " s after its last report: send again later, or raise --vehicles",
                    {{"Retry-After", after}}};
  }
  if (!known) ++h.vehicle_count;
  of_map[id] = v;
  const json out = vehicle_json(id, v, now);
  h.broadcast(map, sse_record("vehicle", out));
  ApiResponse r = json_response(200, out, route);
  r.headers = {{"Cache-Control", "no-store"}};
  return r;
}

ApiResponse Viewer::vehicles(const std::string& map) {
  Impl& h = *impl_;
  const auto now = std::chrono::steady_clock::now();
  json list = json::array();
  {
    std::lock_guard<std::mutex> lock(h.hub_mutex);
    h.sweep(now);
    auto it = h.vehicles.find(map);
    if (it != h.vehicles.end())
      for (const auto& [id, v] : it->second) list.push_back(vehicle_json(id, v, now));
  }
  ApiResponse r = json_response(200, {{"map", map}, {"timeout_s", h.vehicle_timeout_s}, {"vehicles", list}}, "/v1/maps/{map}/vehicles");
  r.headers = {{"Cache-Control", "no-store"}};  // live: a cache must not keep it
  return r;
}

ApiResponse Viewer::events(const std::string& map, bool head) {
  ApiResponse r;
  r.route = "/v1/maps/{map}/events";
  r.content_type = "text/event-stream";
  // no-store: never cached; X-Accel-Buffering: nginx in front passes each record on at once.
  r.headers = {{"Cache-Control", "no-store"}, {"X-Accel-Buffering", "no"}};
  if (head) return r;
  Impl& h = *impl_;
  auto stream = std::make_shared<EventStream>();
  const auto now = std::chrono::steady_clock::now();
  std::lock_guard<std::mutex> lock(h.hub_mutex);
  if (h.live_streams() >= h.max_streams)
    throw HttpError{503,
                    "this server has " + std::to_string(h.max_streams) +
                        " event streams open, its limit (pl-server --event-streams): retry later, or raise the limit",
                    {{"Retry-After", "5"}}};
  h.sweep(now);
  // First what the page needs to start: how long a silent vehicle stays (it drops them itself
  // too), then every vehicle heard from lately; updates follow as they come.
  std::string first = "retry: 2000\n\n";
  first += sse_record("hello", {{"map", map}, {"timeout_s", h.vehicle_timeout_s}, {"keepalive_s", EventStream::kKeepAliveSeconds}});
  auto it = h.vehicles.find(map);
  if (it != h.vehicles.end())
    for (const auto& [id, v] : it->second) first += sse_record("vehicle", vehicle_json(id, v, now));
  stream->push(first);
  h.streams[map].push_back(stream);
  r.events = std::move(stream);
  return r;
}

}  // namespace pl::server

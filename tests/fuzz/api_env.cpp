#include "api_env.hpp"

#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <tuple>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <memory>
#include <nlohmann/json.hpp>
#include <string_view>

#include "pl/common/error.hpp"
#include "pl/common/tile_codec.hpp"
#include "pl/schema/change_report.hpp"
#include "pl/schema/store.hpp"

namespace fs = std::filesystem;

namespace pl::fuzz {

namespace {

[[noreturn]] void finding(const std::string& what, const server::ApiRequest& req, const server::ApiResponse& r) {
  std::fprintf(stderr, "FINDING: %s\n  request: %s %s\n  answer %d: %.400s\n", what.c_str(), req.method.c_str(), req.target.c_str(),
               r.status, r.body.c_str());
  std::abort();
}

std::string inflate_gzip(std::string_view in, bool& ok) {
  z_stream z{};
  ok = false;
  if (inflateInit2(&z, 15 + 16) != Z_OK) return {};
  std::string out;
  char buf[16384];
  z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(in.data()));
  z.avail_in = static_cast<uInt>(in.size());
  int rc = Z_OK;
  while (rc == Z_OK) {
    z.next_out = reinterpret_cast<Bytef*>(buf);
    z.avail_out = sizeof(buf);
    rc = inflate(&z, Z_NO_FLUSH);
    out.append(buf, sizeof(buf) - z.avail_out);
  }
  inflateEnd(&z);
  ok = rc == Z_STREAM_END;
  return out;
}

// A drive's change report against version 1: the raised points of tile (0, 0) passed through, a
// face added at y = 15.1 with its sample (two of them make tile (0, 0) a change candidate).
std::string town_report(const std::string& vehicle, double start) {
  schema::ChangeReport r;
  r.map = "town";
  r.version = 1;
  r.vehicle = vehicle;
  r.drive = "d1";
  r.start = start;
  r.end = start + 60;
  r.voxel_m = 0.5;
  r.tile_m = 20;
  schema::TileChangeEvidence t;
  t.key = {0, 0};
  t.scans = 30;
  for (int i = 0; i < 24; i += 3) {
    const double x = 1 + 18 * ((i % 6) / 6.0), y = 1 + 18 * ((i / 6) / 4.0);
    t.cells.push_back({static_cast<std::int32_t>(std::floor(x / 0.5)), static_cast<std::int32_t>(std::floor(y / 0.5)), 4, 0, 0, 0, 6});
  }
  for (int x = 20; x < 26; ++x) t.cells.push_back({x, 30, 2, 8, 0, 0, 0});
  std::sort(t.cells.begin(), t.cells.end(), [](const auto& a, const auto& b) { return std::tie(a.x, a.y, a.z) < std::tie(b.x, b.y, b.z); });
  for (int x = 1000; x < 1300; x += 20) t.points.push_back({x, 1510, 110});
  r.tiles = {t};
  return schema::change_report_json(r);
}

class Env {
 public:
  Env() {
    std::string base = fs::exists("/dev/shm") ? "/dev/shm" : fs::temp_directory_path().string();
    std::string tmpl = base + "/pl-fuzz-api-XXXXXX";
    if (!mkdtemp(tmpl.data())) std::abort();
    dir_ = tmpl;
    pristine_ = dir_ + "/pristine.sqlite";
    {
      auto store = store::Store::open(pristine_, true);
      store.create_map("town", GeoPoint{48.98, 8.39, 110.0}, 20.0, 0.2);
      auto v1 = store.create_version("town", std::nullopt, "first drive");
      for (auto [tx, ty] : {std::pair{0, 0}, {1, 0}, {-1, 2}}) {
        std::string bytes = town_tile(tx, ty);
        TileCloud c = decode_tile(bytes);
        Eigen::Vector3d lo = c.points[0], hi = lo;
        for (const auto& p : c.points) lo = lo.cwiseMin(p), hi = hi.cwiseMax(p);
        store.put_tile("town", v1.number, TileKey{tx, ty}, bytes, static_cast<std::int64_t>(c.size()), lo.x(), lo.y(), lo.z(), hi.x(),
                       hi.y(), hi.z());
      }
      store.put_places("town", v1.number, kTownPlaces);
      store.publish("town", v1.number);
      for (const auto& [vehicle, start] : {std::pair{"vehicle-1", 1.8e9}, {"vehicle-2", 1.8e9 + 86400}}) {
        const std::string report = town_report(vehicle, start);
        store.put_report("town", 1, vehicle, "d1", start, start + 60, report, "fuzz");
      }
      store.create_version("town", std::nullopt, "staged");
      store.add_token(kReadToken, store::Role::Read, "fuzz");
      store.add_token(kReportToken, store::Role::Report, "fuzz");
      store.add_token(kUploadToken, store::Role::Upload, "fuzz");
      store.add_token(kAdminToken, store::Role::Admin, "fuzz");
    }
    std::ifstream in(pristine_, std::ios::binary);
    pristine_bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
    if (pristine_bytes_.empty()) std::abort();
  }
  ~Env() {
    std::error_code ec;
    fs::remove_all(dir_, ec);
  }

  server::ApiResponse handle(const server::ApiRequest& req) {
    const std::string path = dir_ + "/run-" + std::to_string(++run_) + ".sqlite";
    // Written from memory, not with fs::copy_file: its sendfile() is not retried when a signal
    // interrupts it, and libFuzzer's timeout timer sends SIGALRM every few seconds (a run of an hour
    // threw "cannot copy file: Interrupted system call"); a stream's writes are retried.
    {
      std::ofstream out(path, std::ios::binary | std::ios::trunc);
      out.write(pristine_bytes_.data(), static_cast<std::streamsize>(pristine_bytes_.size()));
      if (!out) {
        std::fprintf(stderr, "cannot write %s\n", path.c_str());
        std::abort();
      }
    }
    server::ApiResponse r;
    {
      server::Metrics metrics;
      server::ApiConfig cfg;
      cfg.db = path;
      server::Api api(cfg, metrics);  // switches this thread's store connection to the fresh copy
      remove_run(run_ - 1);
      r = api.handle(req);
    }
    return r;
  }

 private:
  void remove_run(long n) {
    std::error_code ec;
    const std::string p = dir_ + "/run-" + std::to_string(n) + ".sqlite";
    for (const char* suffix : {"", "-wal", "-shm"}) fs::remove(p + suffix, ec);
  }
  std::string dir_, pristine_, pristine_bytes_;
  long run_ = 0;
};

}  // namespace

std::string town_tile(int tx, int ty) {
  TileCloud c;
  for (int i = 0; i < 24; ++i) {
    const double u = (i % 6) / 6.0, v = (i / 6) / 4.0;
    c.points.emplace_back(20.0 * tx + 1 + 18 * u, 20.0 * ty + 1 + 18 * v, i % 3 == 0 ? 2.0 : 0.0);
    c.normals.emplace_back(0.0f, 0.0f, 1.0f);
    c.intensity.push_back(static_cast<float>(i) / 24.0f);
  }
  return encode_tile(c);
}

server::ApiResponse handle_checked(const server::ApiRequest& req) {
  static Env env;
  server::ApiResponse r = env.handle(req);
  static const int known[] = {200, 201, 204, 301, 304, 400, 401, 403, 404, 405, 409, 413, 415, 422, 503};  // 301: /viewer to /viewer/
  bool documented = false;
  for (int k : known) documented |= r.status == k;
  if (!documented) finding("status " + std::to_string(r.status) + " (500: an exception nobody expected)", req, r);
  auto header = [&](const std::string& name) -> const std::string* {
    for (const auto& [k, v] : r.headers)
      if (k == name) return &v;
    return nullptr;
  };
  if (r.status == 405 && !header("Allow")) finding("405 without Allow", req, r);
  if (r.status == 401 && !header("WWW-Authenticate")) finding("401 without WWW-Authenticate", req, r);
  if (r.content_type == "application/json" && !r.blob) {
    std::string body = r.body;
    if (const std::string* enc = header("Content-Encoding")) {
      if (*enc != "gzip") finding("unknown Content-Encoding " + *enc, req, r);
      bool ok = false;
      body = inflate_gzip(r.body, ok);
      if (!ok) finding("gzip body that does not inflate", req, r);
    }
    // nlohmann::json refuses invalid UTF-8: a body that does not parse is what crashed the server.
    auto j = nlohmann::json::parse(body, nullptr, false);
    if (j.is_discarded()) finding("JSON answer that does not parse (invalid UTF-8?)", req, r);
    if (r.status >= 400 && !(j.is_object() && j.contains("error") && j["error"].is_string())) finding("error without a message", req, r);
  }
  return r;
}

}  // namespace pl::fuzz

// The fleet's change reports and the map updates made from them (see api_parts.hpp):
//   POST /v1/maps/{map}/reports   a vehicle's report of one drive (report role), idempotent by drive
//   GET  /v1/maps/{map}/reports   the reports received (upload role): who, when, against which version
//   GET  /v1/maps/{map}/changes   the tiles the reports agree changed, per tile (for the viewer's heat map)
//   POST /v1/maps/{map}/update    stage (and publish) a version rebuilt from them (admin role)
#include <cmath>

#include "api_parts.hpp"
#include "pl/common/error.hpp"
#include "pl/common/gzip.hpp"
#include "pl/maps/change_detect.hpp"
#include "pl/maps/map_update.hpp"
#include "pl/schema/change_report.hpp"

namespace pl::server::api_parts {

namespace {

maps::ChangeRule rule_from(const json& j) {
  maps::ChangeRule rule;
  auto whole = [&](const char* key, auto& into, long lo, long hi) {
    if (!j.contains(key)) return;
    if (!j[key].is_number_integer() || (j[key].is_number_unsigned() && j[key].get<std::uint64_t>() > static_cast<std::uint64_t>(hi)) ||
        j[key].get<long>() < lo || j[key].get<long>() > hi)
      fail(400, std::string("\"") + key + "\" must be a whole number within " + std::to_string(lo) + ".." + std::to_string(hi));
    into = static_cast<std::remove_reference_t<decltype(into)>>(j[key].get<long>());
  };
  whole("min_drives", rule.min_drives, 1, 100);
  whole("window", rule.window, 1, 1000);
  whole("min_cells", rule.min_cells, 1, 1000000);
  try {
    rule.validate();
  } catch (const Error& e) {
    fail(400, e.what());
  }
  return rule;
}

}  // namespace

ApiResponse post_report(store::Store& db, const ApiRequest& req, const std::string& map, const std::string& by) {
  const std::string route = "/v1/maps/{map}/reports";
  const schema::ChangeReportLimits limits;
  std::string inflated;
  std::string_view body = req.body;
  if (req.content_encoding == "gzip") {
    try {
      inflated = gunzip(req.body, limits.max_bytes);
    } catch (const GzipTooLarge&) {
      fail(413, "the report inflates to more than " + std::to_string(limits.max_bytes >> 20) +
                    " MiB: send the drive's evidence in several reports");
    } catch (const Error& e) {
      fail(400, std::string("the body is not valid gzip (") + e.what() +
                    "): send the report's JSON gzipped with Content-Encoding: gzip, or plain without it");
    }
    body = inflated;
  } else if (!req.content_encoding.empty() && req.content_encoding != "identity") {
    fail(415, "Content-Encoding " + req.content_encoding + " is not taken here: send the report plain or gzip");
  }
  if (body.empty()) fail(422, "the body is empty: POST a change report (JSON, pl-localize --change-report writes one)");
  schema::ChangeReport r;
  try {
    r = schema::parse_change_report(body, limits);
  } catch (const Error& e) {
    fail(422, e.what());
  }
  if (r.map != map) fail(422, "the report is of map " + r.map + ", not " + map + ": POST it to /v1/maps/" + r.map + "/reports");
  const auto m = db.find_map(map);
  if (!m) fail(404, "no map named \"" + map + "\"");
  const auto v = db.find_version(map, r.version);
  if (!v || v->state == store::VersionState::Staged)
    fail(422, "map " + map + " has no published version " + std::to_string(r.version) + " for the report to be against");
  if (std::abs(r.tile_m - m->tile_size) > 1e-9)
    fail(422, "the report's tiles are " + std::to_string(r.tile_m) + " m, the map's " + std::to_string(m->tile_size) + " m");
  const auto put = db.put_report(map, r.version, r.vehicle, r.drive, r.start, r.end, body, by);
  if (put == store::Store::ReportPut::Conflict)
    fail(409, "vehicle " + r.vehicle + " reported drive " + r.drive + " already, with other content: a drive is reported once "
              "(give each drive its own id)");
  const bool stored = put == store::Store::ReportPut::Stored;
  return json_response(stored ? 201 : 200,
                       {{"map", map}, {"version", r.version}, {"vehicle", r.vehicle}, {"drive", r.drive}, {"stored", stored},
                        {"tiles", r.tiles.size()}},
                       route);
}

ApiResponse list_reports(store::Store& db, const Target& t, const std::string& map) {
  if (!db.find_map(map)) fail(404, "no map named \"" + map + "\"");
  std::optional<std::int64_t> version;
  if (t.query.count("version")) version = parse_version(t.query.at("version"));
  json list = json::array();
  for (const auto& r : db.list_reports(map, version))
    list.push_back({{"id", r.id}, {"version", r.version}, {"vehicle", r.vehicle}, {"drive", r.drive}, {"start", r.start},
                    {"end", r.end}, {"bytes", r.bytes}, {"hash", r.hash}, {"received", r.received}, {"who", r.who}});
  return json_response(200, {{"map", map}, {"reports", list}}, "/v1/maps/{map}/reports");
}

ApiResponse changes(store::Store& db, const Target& t, const std::string& map) {
  const auto m = db.find_map(map);
  if (!m) fail(404, "no map named \"" + map + "\"");
  std::int64_t version = m->current.value_or(0);
  if (t.query.count("version")) version = parse_version(t.query.at("version"));
  json q = json::object();
  for (const char* k : {"min_drives", "window", "min_cells"})
    if (t.query.count(k)) {
      q[k] = json::parse(t.query.at(k), nullptr, false);
      if (q[k].is_discarded()) fail(400, std::string("\"") + k + "\" must be a whole number");
    }
  const maps::ChangeSummary s = maps::detect_changes(maps::stored_reports(db, map, version), version, rule_from(q));
  json tiles = json::array();
  for (const auto& c : s.tiles) {
    tiles.push_back({{"tx", c.key.tx}, {"ty", c.key.ty}, {"passes", c.passes.size()}, {"agreed", c.agreed},
                     {"added_voxels", c.added.size()}, {"removed_voxels", c.removed.size()}, {"candidate", c.candidate}});
  }
  return json_response(200, {{"map", map}, {"version", version}, {"reports", s.reports}, {"passes", s.used}, {"tiles", tiles}},
                       "/v1/maps/{map}/changes");
}

ApiResponse update(store::Store& db, const ApiRequest& req, const std::string& map, const std::string& by,
                   const std::function<void(std::int64_t)>& publish) {
  json j = json::object();
  if (!req.body.empty()) {
    j = json::parse(req.body, nullptr, false);
    if (!j.is_object())
      fail(400, "expected no body, or {\"min_drives\": N, \"window\": N, \"min_cells\": N, \"publish\": BOOL, \"note\": TEXT}");
  }
  const auto m = db.find_map(map);
  if (!m) fail(404, "no map named \"" + map + "\"");
  if (!m->current) fail(409, "map " + map + " has no published version to update");
  maps::MapUpdateConfig cfg;
  cfg.rule = rule_from(j);
  cfg.who = by;
  if (j.contains("note")) {
    if (!j["note"].is_string()) fail(400, "\"note\" must be text");
    cfg.note = j["note"].get<std::string>();
  }
  const bool and_publish = j.contains("publish") && j["publish"].is_boolean() && j["publish"].get<bool>();
  const maps::MapUpdateResult r = maps::update_map(db, map, maps::stored_reports(db, map, *m->current), cfg);
  json tiles = json::array();
  for (const auto& u : r.tiles)
    tiles.push_back({{"tx", u.key.tx}, {"ty", u.key.ty}, {"before", u.before}, {"removed", u.removed}, {"added", u.added},
                     {"after", u.after}, {"deleted", u.deleted}, {"reason", u.reason()}});
  std::size_t candidates = 0;
  for (const auto& t : r.summary.tiles) candidates += t.candidate;
  json out = {{"map", map}, {"parent", r.parent}, {"reports", r.summary.reports}, {"passes", r.summary.used},
              {"candidates", candidates}, {"tiles", tiles}, {"unchanged", r.unchanged}};
  if (!r.version) {
    out["version"] = nullptr;
    return json_response(200, out, "/v1/maps/{map}/update");
  }
  out["version"] = r.version->number;
  out["state"] = "staged";
  if (and_publish) {
    publish(r.version->number);
    out["state"] = "published";
  }
  return json_response(201, out, "/v1/maps/{map}/update");
}

}  // namespace pl::server::api_parts

// The exact copy of a whole store between engines (pl/schema/store_copy.hpp, pl-map migrate): a
// SQLite store with every kind of row is copied to PostgreSQL and back to SQLite, and the three are
// compared row by row (ids, timestamps and history included), by their digests and by what they do
// (rollbacks, tokens, blob bytes, change reports). A destination that is not empty is refused untouched, and a copy
// that fails half-way (a damaged source, a value the destination cannot hold) leaves it empty.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "error_of.hpp"
#include "pl/common/error.hpp"
#include "pl/schema/signed_manifest.hpp"
#include "pl/schema/store.hpp"
#include "pl/schema/store_copy.hpp"
#include "store_backends.hpp"
#include "store_test_util.hpp"
#include "test_util.hpp"

namespace {

using pl::store::Role;
using pl::store::Store;
using pl::store::VersionState;
using pl::test::Backend;
using pl::test::put_cell;

const pl::GeoPoint kOrigin{48.1, 11.5, 520.0};

// Every row of every table of a SQLite store file, with each value's type: sqlite_sequence (the
// upload log's next id) and the R*Tree's entries included. Equal dumps: equal files, row for row.
std::string dump_sqlite(const std::string& path) {
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr) != SQLITE_OK) {
    sqlite3_close_v2(db);
    throw std::runtime_error("cannot open " + path);
  }
  std::string out;
  for (const char* table : {"maps", "versions", "blobs", "tiles", "tile_rtree", "places", "signatures", "tokens",
                            "upload_log", "change_reports", "sqlite_sequence"}) {
    out += std::string("== ") + table + "\n";
    sqlite3_stmt* st = nullptr;
    const std::string sql = std::string("SELECT * FROM ") + table + " ORDER BY 1";
    if (sqlite3_prepare_v2(db, sql.c_str(), -1, &st, nullptr) != SQLITE_OK) {
      sqlite3_close_v2(db);
      throw std::runtime_error("cannot read " + std::string(table));
    }
    while (sqlite3_step(st) == SQLITE_ROW) {
      for (int c = 0; c < sqlite3_column_count(st); ++c) {
        switch (sqlite3_column_type(st, c)) {
          case SQLITE_NULL:
            out += "NULL";
            break;
          case SQLITE_INTEGER:
            out += "i" + std::to_string(sqlite3_column_int64(st, c));
            break;
          case SQLITE_FLOAT: {
            char buf[64];
            std::snprintf(buf, sizeof(buf), "f%.17g", sqlite3_column_double(st, c));
            out += buf;
            break;
          }
          case SQLITE_TEXT:
            out += "t'" + std::string(reinterpret_cast<const char*>(sqlite3_column_text(st, c))) + "'";
            break;
          default:
            out += "b" + pl::store::content_hash(std::string(static_cast<const char*>(sqlite3_column_blob(st, c)),
                                                             static_cast<std::size_t>(sqlite3_column_bytes(st, c))));
        }
        out += ",";
      }
      out += "\n";
    }
    sqlite3_finalize(st);
  }
  sqlite3_close_v2(db);
  return out;
}

// What a store answers through its public calls, for every map, version, tile, blob, places,
// signature, token, log entry and change report: two stores with the same answers look the same to
// every user.
std::string answers(const Store& s, const std::vector<std::string>& log_names) {
  std::string out;
  for (const auto& m : s.list_maps()) {
    out += "map " + std::to_string(m.id) + " " + m.name + " " + std::to_string(m.origin.lat_deg) + " " +
           std::to_string(m.origin.lon_deg) + " " + std::to_string(m.origin.alt_m) + " " + std::to_string(m.tile_size) +
           " " + std::to_string(m.voxel_size) + " " + (m.current ? std::to_string(*m.current) : "-") + " " + m.created + "\n";
    for (const auto& v : s.list_versions(m.name)) {
      out += " version " + std::to_string(v.number) + " " + (v.parent ? std::to_string(*v.parent) : "-") + " " +
             pl::store::state_name(v.state) + " " + v.created + " [" + v.note + "] " + std::to_string(v.tiles) + " " +
             std::to_string(v.points) + " " + std::to_string(v.bytes) + "\n";
      for (const auto& t : s.list_tiles(m.name, v.number)) {
        out += "  tile " + std::to_string(t.key.tx) + "," + std::to_string(t.key.ty) + " " + t.hash + " " +
               std::to_string(t.points) + " " + std::to_string(t.bytes) + " " + std::to_string(t.min_x) + " " +
               std::to_string(t.max_y) + " " + std::to_string(t.max_z) + "\n";
        const auto bytes = s.blob(t.hash);
        out += "  blob " + (bytes ? pl::store::content_hash(*bytes) : std::string("missing")) + "\n";
      }
      const auto places = s.places(m.name, v.number);
      out += "  places " + (places ? pl::store::content_hash(*places) : std::string("-")) + "\n";
      const auto sig = s.signature(m.name, v.number);
      out += "  signature " + (sig ? pl::store::content_hash(sig->public_key + sig->signature) + " " + sig->signed_at : "-") + "\n";
    }
    for (const auto& r : s.list_reports(m.name)) {
      char span[80];
      std::snprintf(span, sizeof(span), "%.17g %.17g", r.start, r.end);
      const auto body = s.report_body(m.name, r.id);
      out += " report " + std::to_string(r.id) + " " + r.map + " v" + std::to_string(r.version) + " " + r.vehicle + " " +
             r.drive + " " + span + " " + r.hash + " " + std::to_string(r.bytes) + " " + r.received + " [" + r.who + "] " +
             (body ? pl::store::content_hash(*body) : std::string("missing")) + "\n";
    }
  }
  for (const auto& t : s.list_tokens())
    out += "token " + std::to_string(t.id) + " " + pl::store::role_name(t.role) + " [" + t.note + "] " + t.created + " " +
           (t.revoked ? *t.revoked : "-") + "\n";
  for (const auto& name : log_names)
    for (const auto& e : s.upload_log(name))
      out += "log " + std::to_string(e.id) + " " + e.at + " " + e.map + " " + (e.version ? std::to_string(*e.version) : "-") +
             " " + e.action + " [" + e.detail + "] " + e.who + "\n";
  return out;
}

// Publishes a staged version signed with `key` (a real Ed25519 signature of its manifest).
void publish_signed(Store& s, const std::string& map, std::int64_t version, const pl::signing::SigningKey& key) {
  const std::string text = pl::signing::manifest_text(pl::signing::manifest_of(s, map, version));
  Store::Transaction tx(s);
  pl::signing::sign_staged_version(s, map, version, key.public_key(), key.sign(text));
  s.publish(map, version);
  tx.commit();
}

struct Filled {
  std::vector<std::string> tokens;  // [0] read, [1] upload (revoked), [2] admin, [3] report
  std::vector<std::string> log_names = {"campus", "harbour", "empty", "nowhere"};
};

// A store with every kind of row: three maps (one without versions), versions in all three states,
// a publish history with a rollback in it, shared blobs, places, real signatures, tokens (one
// revoked) and upload log entries (one for a map that does not exist, some without a version), and
// change reports (against published, retired and staged versions, binary bytes, of two vehicles).
Filled fill(const std::string& path) {
  Filled f;
  Store s = Store::open(path);
  const auto key = pl::signing::SigningKey::from_seed(std::string(32, '\x07'));
  s.create_map("campus", kOrigin, 20.0, 0.2);
  s.create_map("harbour", {-33.86, 151.21, -3.5}, 25.0, 0.1);
  s.create_map("empty", {0, 0, 0}, 10.0, 0.5);
  // campus: v1 and v2 published then retired, v3 published unsigned, rolled back by v4 (v2's content),
  // v5 staged, v6 published and signed (current).
  s.create_version("campus", std::nullopt, "first drive");
  put_cell(s, "campus", 1, 0, 0, 1);
  put_cell(s, "campus", 1, 1, 0, 2);
  put_cell(s, "campus", 1, -1, 3, 3, 1000);
  s.put_places("campus", 1, "places of v1");
  publish_signed(s, "campus", 1, key);
  s.create_version("campus", std::nullopt, "second drive: a new tile");
  put_cell(s, "campus", 2, 2, 2, 4);
  s.delete_tile("campus", 2, {1, 0});
  publish_signed(s, "campus", 2, key);
  s.create_version("campus", 1, "from v1, \xc3\xa9t\xc3\xa9");  // UTF-8 note
  put_cell(s, "campus", 3, 0, 0, 5);                          // replaces a tile: a new blob
  s.put_places("campus", 3, "places of v3");
  s.publish("campus", 3);  // unsigned
  EXPECT_EQ(s.rollback("campus"), 4);
  s.create_version("campus", 2, "from v2, staged");
  put_cell(s, "campus", 5, 5, 5, 6);
  s.create_version("campus", 2, "from v2, published after the rollback");
  put_cell(s, "campus", 6, 6, 6, 1);  // the same bytes as tile (0, 0) of v1: one blob
  publish_signed(s, "campus", 6, key);
  // harbour: v1 published (current), v2 staged with places and a tile of its own.
  s.create_version("harbour", std::nullopt, "");
  put_cell(s, "harbour", 1, 10, -10, 7, 4096);
  s.publish("harbour", 1);
  s.create_version("harbour", std::nullopt, "staged");
  s.put_places("harbour", 2, std::string("\0binary\xff places", 15));
  put_cell(s, "harbour", 2, 11, -10, 8);
  // Tokens: read, upload (revoked), admin, report.
  for (Role role : {Role::Read, Role::Upload, Role::Admin, Role::Report}) {
    f.tokens.push_back(pl::store::random_token());
    s.add_token(f.tokens.back(), role, std::string("for ") + pl::store::role_name(role));
  }
  EXPECT_TRUE(s.revoke_token(2));
  // The upload log, a map that does not exist included.
  s.log_upload("campus", 1, "publish", "signed by key 1234", "token 3");
  s.log_upload("campus", std::nullopt, "upload", "refused: too big", "token 1");
  s.log_upload("nowhere", 7, "publish", "unknown map", "");
  s.log_upload("harbour", 1, "publish", "tabs\tand\nnewlines", "token 3");
  s.log_upload("campus", 4, "rollback", "", "admin");
  // Change reports: campus v1 (retired), v6 (current) and v5 (staged); harbour v1.
  using Put = Store::ReportPut;
  EXPECT_EQ(s.put_report("campus", 1, "car-7", "drive-1", 1714550000.125, 1714553600.75, R"({"drive":"drive-1"})", "token 4"),
            Put::Stored);
  EXPECT_EQ(s.put_report("campus", 6, "car-7", "drive-2", -0.0, 1e-300, std::string("\0binary\xff report", 15), "token 4"),
            Put::Stored);
  EXPECT_EQ(s.put_report("campus", 5, "car-8", "drive-1", 1, 1, std::string(70000, 'r'), "token 4"), Put::Stored);
  EXPECT_EQ(s.put_report("harbour", 1, "car-8", "drive-3", 2, 3, "{}", "tabs\tand \xc3\xa9"), Put::Stored);
  EXPECT_TRUE(s.integrity_ok());
  return f;
}

// Runs the store's rollbacks until it has none left: the versions it made current with the version
// whose content each holds, and the error.
std::string rollbacks(const std::string& path) {
  Store s = Store::open(path, false);
  std::string out;
  for (const auto& m : s.list_maps()) {
    out += m.name + ":";
    for (int i = 0; i < 6; ++i) {
      try {
        const auto v = s.rollback(m.name);
        out += " " + std::to_string(v) + "(" + std::to_string(s.find_version(m.name, v)->parent.value_or(0)) + ")";
      } catch (const pl::Error&) {
        out += " none";
        break;
      }
    }
    out += "\n";
  }
  return out;
}

// The counts of the tables that must stay empty after a refused or failed copy.
std::int64_t rows_in(Backend b, const std::string& path) {
  std::int64_t n = 0;
  for (const char* t : {"maps", "versions", "blobs", "tiles", "places", "signatures", "tokens", "upload_log", "change_reports"})
    n += pl::test::raw_scalar(b, path, std::string("SELECT count(*) FROM ") + t);
  return n;
}

std::string answers_of(const std::string& path, const Filled& f) { return answers(Store::open(path, false), f.log_names); }

}  // namespace

// SQLite -> PostgreSQL -> SQLite: every row, id, timestamp and byte the same; the same digest; the
// same behaviour (rollbacks walk the same history, tokens open the same doors).
TEST(StoreCopy, SqliteToPostgresAndBackIsExact) {
  pl::test::TempDir dir;
  const std::string src = dir / "src.db", back = dir / "back.db";
  std::string pg;
  try {
    pg = pl::test::PgCluster::get().new_database();
  } catch (const std::exception& e) {
    FAIL() << e.what();
  }
  const Filled f = fill(src);
  const std::string digest = pl::store::store_digest(src);

  std::vector<std::string> stages;
  const auto report = pl::store::copy_store(src, pg, [&](const std::string& stage, std::size_t, std::size_t) {
    if (stages.empty() || stages.back() != stage) stages.push_back(stage);
  });
  EXPECT_EQ(report.maps, 3);
  EXPECT_EQ(report.versions, 8);
  EXPECT_EQ(report.tokens, 4);
  EXPECT_EQ(report.log_entries, 5);
  EXPECT_EQ(report.reports, 4);
  EXPECT_EQ(report.signatures, 3);
  EXPECT_EQ(report.places, 7);  // campus 1 to 6 (2, 4, 5 and 6 inherited theirs), harbour 2
  EXPECT_EQ(report.places, pl::test::raw_scalar(Backend::Sqlite, src, "SELECT count(*) FROM places"));
  EXPECT_EQ(report.tiles, pl::test::raw_scalar(Backend::Sqlite, src, "SELECT count(*) FROM tiles"));
  EXPECT_EQ(report.blobs, pl::test::raw_scalar(Backend::Sqlite, src, "SELECT count(*) FROM blobs"));
  EXPECT_EQ(report.blob_bytes, pl::test::raw_scalar(Backend::Sqlite, src, "SELECT sum(size) FROM blobs"));
  EXPECT_EQ(report.digest, digest);
  EXPECT_EQ(stages, (std::vector<std::string>{"maps", "versions", "blobs", "tiles", "places", "signatures", "tokens",
                                              "upload log", "change reports", "verifying"}));
  EXPECT_EQ(pl::store::store_digest(pg), digest);
  EXPECT_TRUE(Store::open(pg, false).integrity_ok());

  const auto report_back = pl::store::copy_store(pg, back);
  EXPECT_EQ(report_back.digest, digest);
  EXPECT_EQ(pl::store::store_digest(back), digest);
  EXPECT_TRUE(Store::open(back, false).integrity_ok());

  // Row for row, ids, timestamps, history columns (published, replaces), the R*Tree and the upload
  // log's sequence included.
  EXPECT_EQ(dump_sqlite(back), dump_sqlite(src));
  // The same answers from all three, PostgreSQL included.
  const std::string want = answers_of(src, f);
  EXPECT_NE(want.find("retired"), std::string::npos);
  EXPECT_NE(want.find("staged"), std::string::npos);
  EXPECT_NE(want.find("published"), std::string::npos);
  EXPECT_NE(want.find(" report "), std::string::npos);
  EXPECT_EQ(answers_of(pg, f), want);
  EXPECT_EQ(answers_of(back, f), want);
  // The history columns on PostgreSQL, against the source's.
  for (const char* sql : {"SELECT count(*) FROM versions WHERE published IS NOT NULL",
                          "SELECT coalesce(sum(replaces * number), 0) FROM versions",
                          "SELECT coalesce(sum(id * number), 0) FROM versions"})
    EXPECT_EQ(pl::test::pg_scalar(pg, sql), pl::test::raw_scalar(Backend::Sqlite, src, sql)) << sql;

  // Tokens: the two in force open the copies with their roles, the revoked one opens none.
  for (const std::string& path : {src, pg, back}) {
    const Store s = Store::open(path, false);
    EXPECT_EQ(s.check_token(f.tokens[0]), Role::Read) << pl::store::display_name(path);
    EXPECT_EQ(s.check_token(f.tokens[1]), std::nullopt) << pl::store::display_name(path);
    EXPECT_EQ(s.check_token(f.tokens[2]), Role::Admin) << pl::store::display_name(path);
    EXPECT_EQ(s.check_token(f.tokens[3]), Role::Report) << pl::store::display_name(path);
    EXPECT_EQ(s.check_token("not a token"), std::nullopt);
  }
  // Change reports: every body the same in the three, byte for byte.
  {
    const Store a = Store::open(src, false), b = Store::open(pg, false), c = Store::open(back, false);
    int reports = 0;
    for (const auto& m : a.list_maps())
      for (const auto& r : a.list_reports(m.name)) {
        const auto body = a.report_body(m.name, r.id);
        ASSERT_TRUE(body);
        EXPECT_EQ(b.report_body(m.name, r.id), body);
        EXPECT_EQ(c.report_body(m.name, r.id), body);
        ++reports;
      }
    EXPECT_EQ(reports, 4);
    EXPECT_EQ(b.report_body("campus", 2), std::string("\0binary\xff report", 15));
  }
  // Blob bytes: every tile's bytes the same in the three.
  {
    const Store a = Store::open(src, false), b = Store::open(pg, false), c = Store::open(back, false);
    for (const auto& m : a.list_maps())
      for (const auto& v : a.list_versions(m.name))
        for (const auto& t : a.list_tiles(m.name, v.number)) {
          const auto bytes = a.blob(t.hash);
          ASSERT_TRUE(bytes);
          EXPECT_EQ(b.blob(t.hash), bytes);
          EXPECT_EQ(c.blob(t.hash), bytes);
        }
  }
  // The signatures still verify against the copies' own manifests (the same map, versions, tiles).
  for (const std::string& path : {pg, back}) {
    const Store s = Store::open(path, false);
    int verified = 0;
    for (const std::int64_t v : {1, 2, 6}) {
      const auto sig = s.signature("campus", v);
      ASSERT_TRUE(sig) << v;
      EXPECT_TRUE(pl::signing::verify(sig->public_key, pl::signing::manifest_text(pl::signing::manifest_of(s, "campus", v)),
                                      sig->signature))
          << pl::store::display_name(path) << " version " << v;
      ++verified;
    }
    EXPECT_EQ(verified, 3);
    EXPECT_FALSE(s.signature("campus", 3));
    EXPECT_FALSE(s.signature("campus", 4));  // a rollback's copy never inherits a signature
  }
  // Rollbacks walk the same history on each, to the same end: campus 6 -> v7 with v4's content
  // (which was v2's) -> v8 with v1's -> none.
  const std::string walked = rollbacks(src);
  EXPECT_EQ(walked, "campus: 7(4) 8(1) none\nempty: none\nharbour: none\n");
  EXPECT_EQ(rollbacks(pg), walked);
  EXPECT_EQ(rollbacks(back), walked);

  // The copies are stores like any other: new rows get new ids (PostgreSQL's identity sequences
  // were moved past the copied ones).
  for (const std::string& path : {pg, back}) {
    Store s = Store::open(path, false);
    EXPECT_EQ(s.create_map("new", kOrigin, 20, 0.2).id, 4) << pl::store::display_name(path);
    EXPECT_EQ(s.create_version("harbour", std::nullopt, "").number, 3);
    put_cell(s, "harbour", 3, 40, 40, 99);
    EXPECT_EQ(s.add_token(pl::store::random_token(), Role::Read, ""), 5);
    s.log_upload("new", std::nullopt, "create", "", "");
    EXPECT_EQ(s.upload_log("new").at(0).id, 6);
    EXPECT_EQ(s.put_report("harbour", 3, "car-9", "drive-9", 0, 1, "{}", "token 5"), Store::ReportPut::Stored);
    EXPECT_EQ(s.list_reports("harbour", 3).at(0).id, 5);
    EXPECT_EQ(s.put_report("campus", 1, "car-7", "drive-1", 0, 1, "other bytes", "token 5"), Store::ReportPut::Conflict);
    EXPECT_TRUE(s.integrity_ok());
  }
}

class StoreCopyBoth : public pl::test::BackendTest {};

// Same engine to same engine: SQLite -> SQLite and PostgreSQL -> PostgreSQL.
TEST_P(StoreCopyBoth, CopiesWithinOneEngine) {
  const Filled f = fill(dir / "src.db");
  std::string from = dir / "src.db";
  if (!sqlite()) {
    pl::store::copy_store(dir / "src.db", path);
    from = path;
  }
  const std::string to = another("copy.db");
  const auto report = pl::store::copy_store(from, to);
  EXPECT_EQ(report.digest, pl::store::store_digest(dir / "src.db"));
  EXPECT_EQ(pl::store::store_digest(to), report.digest);
  EXPECT_EQ(answers_of(to, f), answers_of(dir / "src.db", f));
  EXPECT_EQ(rollbacks(to), rollbacks(dir / "src.db"));
}

// A destination with anything in it is refused, named, with the fix, and left exactly as it was.
TEST_P(StoreCopyBoth, RefusesADestinationThatIsNotEmpty) {
  fill(dir / "src.db");
  {
    Store s = Store::open(path);
    s.create_map("mine", kOrigin, 20, 0.2);
    s.add_token("a token of the destination", Role::Admin, "");
  }
  const std::string before = pl::store::store_digest(path);
  const std::string err = pl::test::error_of([&] { pl::store::copy_store(dir / "src.db", path); });
  EXPECT_NE(err.find("the map store is not empty (it holds 1 map, 0 tile blobs, 1 token, 0 upload log entries)"),
            std::string::npos)
      << err;
  EXPECT_NE(err.find("migrate into a new SQLite file or an empty PostgreSQL database"), std::string::npos) << err;
  EXPECT_EQ(pl::store::store_digest(path), before);
  EXPECT_EQ(rows_in(GetParam(), path), 2);
  // Only the upload log in it: refused too.
  const std::string logged = another("logged.db");
  Store::open(logged).log_upload("x", std::nullopt, "upload", "", "");
  EXPECT_NE(pl::test::error_of([&] { pl::store::copy_store(dir / "src.db", logged); }).find("1 upload log entry"),
            std::string::npos);
  EXPECT_EQ(rows_in(GetParam(), logged), 1);
}

// A source found damaged half-way (a blob whose bytes no longer hash to it, read after the maps
// and versions were written): the copy fails naming the damage and the destination is left empty
// (a SQLite file it created is gone).
TEST_P(StoreCopyBoth, ASourceDamagedHalfWayLeavesTheDestinationEmpty) {
  const std::string src = dir / "src.db";
  fill(src);
  pl::test::RawDb raw(src);
  ASSERT_EQ(raw.exec("UPDATE blobs SET bytes = zeroblob(size) WHERE hash = (SELECT max(hash) FROM blobs)"), "");
  Store::open(path);  // the destination exists, as an empty store
  const std::string err = pl::test::error_of([&] { pl::store::copy_store(src, path); });
  EXPECT_NE(err.find("the map store is damaged (blobs.bytes of blob"), std::string::npos) << err;
  EXPECT_EQ(rows_in(GetParam(), path), 0);
  EXPECT_TRUE(Store::open(path, false).integrity_ok());
  if (sqlite()) {
    const std::string created = dir / "created.db";
    EXPECT_NE(pl::test::error_of([&] { pl::store::copy_store(src, created); }).find("damaged"), std::string::npos);
    EXPECT_FALSE(std::filesystem::exists(created));
    EXPECT_FALSE(std::filesystem::exists(created + "-wal"));
  }
}

// checked_digest (pl-map check): a sound store's is its store_digest; a store with a blob, places or
// change report whose bytes changed (same size: only the hash tells), which integrity_ok() finds,
// has none.
TEST_P(StoreCopyBoth, CheckedDigestIsThatOfASoundStoreOnly) {
  fill(dir / "src.db");
  const std::string blob_changed = another("blob.db"), places_changed = another("places.db"),
                    report_changed = another("report.db");
  for (const std::string& to : {path, blob_changed, places_changed, report_changed})
    pl::store::copy_store(dir / "src.db", to);
  EXPECT_EQ(pl::store::checked_digest(path), pl::store::store_digest(path));
  const std::string zeros = sqlite() ? "zeroblob(size)" : "decode(repeat('00', size::int), 'hex')";
  ASSERT_EQ(pl::test::raw_exec(GetParam(), blob_changed,
                               "UPDATE blobs SET bytes = " + zeros + " WHERE hash = (SELECT max(hash) FROM blobs)"),
            "");
  // The places of a staged version (a published one's are read-only).
  ASSERT_EQ(pl::test::raw_exec(GetParam(), places_changed,
                               "UPDATE places SET bytes = " + zeros +
                                   " WHERE version = 2 AND map_id = (SELECT id FROM maps WHERE name = 'harbour')"),
            "");
  ASSERT_EQ(pl::test::zero_report_bodies(GetParam(), report_changed), "");
  for (const std::string& damaged : {blob_changed, places_changed, report_changed}) {
    EXPECT_FALSE(Store::open(damaged, false).integrity_ok()) << damaged;
    EXPECT_EQ(pl::store::checked_digest(damaged), std::nullopt) << damaged;
  }
}

// Change reports are content: adding one changes the digest, deleting it again (retention) brings
// the digest back; a store without any has the digest it would have had before schema version 5
// (the empty table adds nothing to it). A report damaged in the source stops the copy.
TEST_P(StoreCopyBoth, ChangeReportsAreInTheDigest) {
  Store s = Store::open(path);
  s.create_map("m", kOrigin, 20.0, 0.2);
  s.create_version("m", std::nullopt, "");
  put_cell(s, "m", 1, 0, 0, 1);
  s.publish("m", 1);
  const std::string without = pl::store::store_digest(path);
  EXPECT_EQ(pl::store::checked_digest(path), without);
  ASSERT_EQ(s.put_report("m", 1, "car", "d-1", 0, 1, "{}", "token 1"), Store::ReportPut::Stored);
  const std::string with = pl::store::store_digest(path);
  EXPECT_NE(with, without);
  EXPECT_EQ(pl::store::checked_digest(path), with);
  // Another report of the same size and hash but another drive: another digest again.
  ASSERT_EQ(s.put_report("m", 1, "car", "d-2", 0, 1, "{}", "token 1"), Store::ReportPut::Stored);
  EXPECT_NE(pl::store::store_digest(path), with);
  EXPECT_EQ(s.delete_reports("m", "9999-12-31T23:59:59.999Z"), 2);
  EXPECT_EQ(pl::store::store_digest(path), without);

  // A copy moves reports both ways, and reports one damaged in the source as damage.
  ASSERT_EQ(s.put_report("m", 1, "car", "d-3", 5, 6, std::string(3000, 'j'), "token 1"), Store::ReportPut::Stored);
  const std::string copy = another("copy.db");
  EXPECT_EQ(pl::store::copy_store(path, copy).reports, 1);
  EXPECT_EQ(pl::store::store_digest(copy), pl::store::store_digest(path));
  EXPECT_EQ(Store::open(copy, false).list_reports("m").at(0).drive, "d-3");
  ASSERT_EQ(pl::test::zero_report_bodies(GetParam(), path), "");
  const std::string err = pl::test::error_of([&] { pl::store::copy_store(path, another("again.db")); });
  EXPECT_NE(err.find("the map store is damaged (change_reports.body of change report"), std::string::npos) << err;
  EXPECT_EQ(pl::store::checked_digest(path), std::nullopt);
}

PL_BOTH_BACKENDS(StoreCopyBoth);

// A tile whose box is inverted (min > max: a crafted file, its CHECK constraints ignored) is refused
// by the copy as by every other read of tiles (read_tile), and nothing is left behind.
TEST(StoreCopy, ATileWithAnInvertedBoxIsDamage) {
  pl::test::TempDir dir;
  const std::string src = dir / "src.db", copy = dir / "copy.db";
  fill(src);
  pl::test::RawDb raw(src);
  ASSERT_EQ(raw.exec("PRAGMA ignore_check_constraints = ON; UPDATE tiles SET min_z = max_z + 1 WHERE version = 5 AND "
                     "map_id = (SELECT id FROM maps WHERE name = 'campus')"),
            "");
  const std::string err = pl::test::error_of([&] { pl::store::copy_store(src, copy); });
  EXPECT_NE(err.find("the map store is damaged (tiles.min_x and the other bounds have min > max)"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(copy));
}

// A write the destination refuses late in the copy (PostgreSQL holds no invalid UTF-8, which a
// SQLite upload log may; the log is the last table copied): the whole copy is rolled back.
TEST(StoreCopy, AFailingDestinationWriteRollsTheWholeCopyBack) {
  pl::test::TempDir dir;
  const std::string src = dir / "src.db";
  fill(src);
  Store::open(src).log_upload("campus", std::nullopt, "upload", "bad \xff bytes", "");
  std::string pg;
  try {
    pg = pl::test::PgCluster::get().new_database();
  } catch (const std::exception& e) {
    FAIL() << e.what();
  }
  const std::string err = pl::test::error_of([&] { pl::store::copy_store(src, pg); });
  EXPECT_NE(err.find("UTF-8"), std::string::npos) << err;
  EXPECT_EQ(rows_in(Backend::Postgres, pg), 0);
  // The destination is still a usable, empty store: the same copy without the bad entry succeeds.
  const std::string clean = dir / "clean.db";
  fill(clean);
  EXPECT_EQ(pl::store::copy_store(clean, pg).digest, pl::store::store_digest(clean));
}

TEST(StoreCopy, RefusesToCopyAStoreOntoItself) {
  pl::test::TempDir dir;
  const std::string src = dir / "src.db";
  fill(src);
  EXPECT_NE(pl::test::error_of([&] { pl::store::copy_store(src, src); }).find("the same store"), std::string::npos);
  EXPECT_NE(pl::test::error_of([&] { pl::store::copy_store(dir / "missing.db", dir / "x.db"); }).find("missing.db"),
            std::string::npos);
  EXPECT_FALSE(std::filesystem::exists(dir / "x.db"));
}

// PostgreSQL reads blobs in batches of at most 32 MiB: a store with more passes through in several,
// each blob whole and in order, and a blob damaged in the database stops the copy with the damaged
// error, creating nothing.
TEST(StoreCopy, BlobsPassThroughPostgresInBatches) {
  pl::test::TempDir dir;
  std::string pg;
  try {
    pg = pl::test::PgCluster::get().new_database();
  } catch (const std::exception& e) {
    FAIL() << e.what();
  }
  const std::string src = dir / "src.db", back = dir / "back.db";
  {
    Store s = Store::open(src);
    s.create_map("big", kOrigin, 20.0, 0.2);
    s.create_version("big", std::nullopt, "");
    for (int i = 0; i < 3; ++i) put_cell(s, "big", 1, i, 0, 100 + i, std::size_t{14} << 20);
    put_cell(s, "big", 1, 5, 5, 7);
    s.publish("big", 1);
  }
  const auto report = pl::store::copy_store(src, pg);
  EXPECT_EQ(report.blobs, 4);
  EXPECT_GT(report.blob_bytes, std::int64_t{42} << 20);
  EXPECT_EQ(pl::store::copy_store(pg, back).digest, report.digest);
  EXPECT_EQ(dump_sqlite(back), dump_sqlite(src));

  ASSERT_EQ(pl::test::pg_exec(pg, "UPDATE blobs SET bytes = overlay(bytes placing 'x'::bytea from 1) WHERE size < 1000"), "");
  const std::string err = pl::test::error_of([&] { pl::store::copy_store(pg, dir / "again.db"); });
  EXPECT_NE(err.find("the map store is damaged (blobs.bytes of blob"), std::string::npos) << err;
  EXPECT_FALSE(std::filesystem::exists(dir / "again.db"));
}

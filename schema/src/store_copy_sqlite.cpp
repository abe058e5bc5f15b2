// The exact copy of a whole store, the SQLite engine's half: every row read verbatim (export_rows)
// and written verbatim (importer) — ids, timestamps, states and publish history included. The copy
// itself (which store to which, the one transaction, the digests) is store_copy.cpp's.
#include <map>
#include <utility>
#include <vector>

#include "pl/common/error.hpp"
#include "store_copy_rows.hpp"
#include "store_internal.hpp"

namespace pl::store::detail {

namespace {

using Table = RowSink::Table;

// The copy's row readers (store_copy_rows.hpp) over a row of a SQLite statement.
class CopyRow : public Row {
 public:
  CopyRow(const Stmt& st, const char* table) : Row(st, table), st_(st) {}
  std::string bytes(int col, const char* column) const { return blob(col, column); }
  std::string timestamp(int col, const char* column) const { return read_timestamp(*this, col, column); }
  std::optional<std::string> opt_timestamp(int col, const char* column) const {
    if (st_.is_null(col)) return std::nullopt;
    return timestamp(col, column);
  }
  VersionState state(int col, const char* column) const { return read_state(*this, col, column); }
  TileRecord tile(int first) const { return read_tile(st_, first); }

 private:
  const Stmt& st_;
};

std::int64_t rows_of(const Db& db, const char* table) {
  return sqlite::query_int(db, (std::string("SELECT count(*) FROM ") + table).c_str());
}

// Hands each row of `sql` (on `table`), as `read` reads it, to `put`. One row at a time: the
// statement steps through the table, SQLite holds the current row only (blobs pass through).
template <typename Read, typename Put>
void each_row(const Db& db, const char* table, const char* sql, Read read, Put put) {
  Stmt st(db, sql);
  while (st.step()) put(read(CopyRow(st, table)));
}

}  // namespace

// ---- reading ---------------------------------------------------------------------------------------

void SqliteStore::export_rows(RowSink& out) const {
  using namespace copy_rows;
  const Db db = conn();
  // A read transaction of its own (WAL: one snapshot, writers go on) unless the connection has one
  // open: the importer's, whose rows are read back before it commits.
  std::optional<sqlite::ReadSnapshot> snapshot;
  if (sqlite3_get_autocommit(db.get()) != 0) snapshot.emplace(db);

  out.begin_table(Table::Maps, rows_of(db, "maps"));
  each_row(db, "maps",
           "SELECT id, name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size, current_version, created "
           "FROM maps ORDER BY id",
           map_row<CopyRow>, [&](const MapRow& m) { out.map(m); });
  out.begin_table(Table::Versions, rows_of(db, "versions"));
  each_row(db, "versions",
           "SELECT id, map_id, number, parent, state, created, note, published, replaces FROM versions ORDER BY id",
           version_row<CopyRow>, [&](const VersionRow& v) { out.version(v); });
  out.begin_table(Table::Blobs, rows_of(db, "blobs"));
  each_row(db, "blobs", "SELECT hash, bytes, size FROM blobs ORDER BY hash", blob_row<CopyRow>,
           [&](const BlobRow& b) { out.blob(b); });
  out.begin_table(Table::Tiles, rows_of(db, "tiles"));
  each_row(db, "tiles",
           "SELECT id, map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z "
           "FROM tiles ORDER BY id",
           tile_row<CopyRow>, [&](const TileRow& t) { out.tile(t); });
  out.begin_table(Table::Places, rows_of(db, "places"));
  each_row(db, "places", "SELECT id, map_id, version, hash, bytes, size FROM places ORDER BY id", places_row<CopyRow>,
           [&](const PlacesRow& p) { out.places(p); });
  out.begin_table(Table::Signatures, rows_of(db, "signatures"));
  each_row(db, "signatures", "SELECT id, map_id, version, public_key, signature, signed FROM signatures ORDER BY id",
           signature_row<CopyRow>, [&](const SignatureRow& s) { out.signature(s); });
  out.begin_table(Table::Tokens, rows_of(db, "tokens"));
  each_row(db, "tokens", "SELECT id, hash, role, note, created, revoked FROM tokens ORDER BY id", token_row<CopyRow>,
           [&](const TokenRow& t) { out.token(t); });
  out.begin_table(Table::UploadLog, rows_of(db, "upload_log"));
  each_row(db, "upload_log", "SELECT id, at, map, version, action, detail, who FROM upload_log ORDER BY id", log_row<CopyRow>,
           [&](const LogRow& e) { out.log(e); });
  out.begin_table(Table::ChangeReports, rows_of(db, "change_reports"));
  each_row(db, "change_reports",
           "SELECT id, version, vehicle, drive, start_s, end_s, hash, size, who, map_id, body, received "
           "FROM change_reports ORDER BY id",
           change_report_row<CopyRow>, [&](const ReportRow& r) { out.report(r); });
  if (snapshot) snapshot->end();
}

StoreContent SqliteStore::content() const {
  const Db db = conn();
  StoreContent c;
  c.maps = rows_of(db, "maps");
  c.blobs = rows_of(db, "blobs");
  c.tokens = rows_of(db, "tokens");
  c.log_entries = rows_of(db, "upload_log");
  return c;
}

// ---- writing ---------------------------------------------------------------------------------------

namespace {

// Rows go in as they were, with their ids, in an order the schema's triggers accept as they stand
// for every writer (none is dropped or disabled, not even for this transaction):
// - maps without their current version, versions all staged without `published` and `replaces`:
//   a version's parent is older than it, so each insert finds its parent;
// - blobs, then tiles, places and signatures, which the *_staged_only triggers accept because every
//   version is still staged;
// - at finish(), the publish history: `published` and `replaces` (no trigger watches them), then
//   each retired version staged -> published -> retired one at a time and each map's published
//   version staged -> published — transitions versions_state_transition allows, with never two
//   published versions of a map (versions_one_published) — and last each map's current version,
//   which maps_current_is_published finds published;
// - tokens, and the upload log, which its triggers let anyone append to;
// - change reports, which no trigger watches on insert (versions in any state take them).
// The R*Tree entries come from tiles_rtree_insert with the tiles' own ids; an explicit id in
// upload_log (AUTOINCREMENT) moves sqlite_sequence past it, so later entries keep counting up.
class SqliteImporter final : public RowSink {
 public:
  explicit SqliteImporter(Db db) : db_(db) {}

  void map(const MapRow& m) override {
    Stmt(db_,
         "INSERT INTO maps (id, name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size, current_version, "
         "created) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, NULL, ?8)")
        .bind_int64(1, m.id)
        .bind_text(2, m.name)
        .bind_double(3, m.origin_lat)
        .bind_double(4, m.origin_lon)
        .bind_double(5, m.origin_alt)
        .bind_double(6, m.tile_size)
        .bind_double(7, m.voxel_size)
        .bind_text(8, m.created)
        .run();
    if (m.current_version) current_[m.id] = *m.current_version;
  }

  void version(const VersionRow& v) override {
    Stmt(db_,
         "INSERT INTO versions (id, map_id, number, parent, state, created, note, published, replaces) "
         "VALUES (?1, ?2, ?3, ?4, 'staged', ?5, ?6, NULL, NULL)")
        .bind_int64(1, v.id)
        .bind_int64(2, v.map_id)
        .bind_int64(3, v.number)
        .bind_opt_int64(4, v.parent)
        .bind_text(5, v.created)
        .bind_text(6, v.note)
        .run();
    history_.push_back(v);
  }

  void blob(const BlobRow& b) override {
    Stmt(db_, "INSERT INTO blobs (hash, bytes, size) VALUES (?1, ?2, ?3)")
        .bind_text(1, b.hash)
        .bind_blob_static(2, b.bytes)
        .bind_int64(3, static_cast<std::int64_t>(b.bytes.size()))
        .run();
  }

  void tile(const TileRow& t) override {
    Stmt(db_,
         "INSERT INTO tiles (id, map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, "
         "max_z) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12, ?13, ?14)")
        .bind_int64(1, t.id)
        .bind_int64(2, t.map_id)
        .bind_int64(3, t.version)
        .bind_int64(4, t.tx)
        .bind_int64(5, t.ty)
        .bind_text(6, t.hash)
        .bind_int64(7, t.points)
        .bind_int64(8, t.bytes)
        .bind_double(9, t.min_x)
        .bind_double(10, t.min_y)
        .bind_double(11, t.min_z)
        .bind_double(12, t.max_x)
        .bind_double(13, t.max_y)
        .bind_double(14, t.max_z)
        .run();
  }

  void places(const PlacesRow& p) override {
    Stmt(db_, "INSERT INTO places (id, map_id, version, hash, bytes, size) VALUES (?1, ?2, ?3, ?4, ?5, ?6)")
        .bind_int64(1, p.id)
        .bind_int64(2, p.map_id)
        .bind_int64(3, p.version)
        .bind_text(4, p.hash)
        .bind_blob_static(5, p.bytes)
        .bind_int64(6, static_cast<std::int64_t>(p.bytes.size()))
        .run();
  }

  void signature(const SignatureRow& s) override {
    Stmt(db_,
         "INSERT INTO signatures (id, map_id, version, public_key, signature, signed) VALUES (?1, ?2, ?3, ?4, ?5, ?6)")
        .bind_int64(1, s.id)
        .bind_int64(2, s.map_id)
        .bind_int64(3, s.version)
        .bind_blob_static(4, s.public_key)
        .bind_blob_static(5, s.signature)
        .bind_text(6, s.signed_at)
        .run();
  }

  void token(const TokenRow& t) override {
    Stmt st(db_, "INSERT INTO tokens (id, hash, role, note, created, revoked) VALUES (?1, ?2, ?3, ?4, ?5, ?6)");
    st.bind_int64(1, t.id).bind_text(2, t.hash).bind_text(3, role_name(t.role)).bind_text(4, t.note).bind_text(5, t.created);
    if (t.revoked) {
      st.bind_text(6, *t.revoked);
    } else {
      st.bind_null(6);
    }
    st.run();
  }

  void log(const LogRow& e) override {
    Stmt(db_, "INSERT INTO upload_log (id, at, map, version, action, detail, who) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7)")
        .bind_int64(1, e.id)
        .bind_text(2, e.at)
        .bind_text(3, e.map)
        .bind_opt_int64(4, e.version)
        .bind_text(5, e.action)
        .bind_text(6, e.detail)
        .bind_text(7, e.who)
        .run();
  }

  void report(const ReportRow& r) override {
    Stmt(db_,
         "INSERT INTO change_reports (id, map_id, version, vehicle, drive, start_s, end_s, hash, body, size, received, "
         "who) VALUES (?1, ?2, ?3, ?4, ?5, ?6, ?7, ?8, ?9, ?10, ?11, ?12)")
        .bind_int64(1, r.id)
        .bind_int64(2, r.map_id)
        .bind_int64(3, r.version)
        .bind_text(4, r.vehicle)
        .bind_text(5, r.drive)
        .bind_double(6, r.start)
        .bind_double(7, r.end)
        .bind_text(8, r.hash)
        .bind_blob_static(9, r.body)
        .bind_int64(10, static_cast<std::int64_t>(r.body.size()))
        .bind_text(11, r.received)
        .bind_text(12, r.who)
        .run();
  }

  void finish() override {
    for (const VersionRow& v : history_) {
      if (!v.published && !v.replaces) continue;
      Stmt st(db_, "UPDATE versions SET published = ?3, replaces = ?4 WHERE map_id = ?1 AND number = ?2");
      st.bind_int64(1, v.map_id).bind_int64(2, v.number);
      if (v.published) {
        st.bind_text(3, *v.published);
      } else {
        st.bind_null(3);
      }
      st.bind_opt_int64(4, v.replaces).run();
    }
    auto set_state = [&](const VersionRow& v, const char* state) {
      Stmt(db_, "UPDATE versions SET state = ?3 WHERE map_id = ?1 AND number = ?2")
          .bind_int64(1, v.map_id)
          .bind_int64(2, v.number)
          .bind_text(3, state)
          .run();
    };
    for (const VersionRow& v : history_) {
      if (v.state != VersionState::Retired) continue;
      set_state(v, "published");
      set_state(v, "retired");
    }
    for (const VersionRow& v : history_)
      if (v.state == VersionState::Published) set_state(v, "published");
    for (const auto& [map_id, number] : current_)
      Stmt(db_, "UPDATE maps SET current_version = ?2 WHERE id = ?1").bind_int64(1, map_id).bind_int64(2, number).run();
  }

 private:
  Db db_;
  std::vector<VersionRow> history_;  // small: no bytes
  std::map<std::int64_t, std::int64_t> current_;
};

}  // namespace

std::unique_ptr<RowSink> SqliteStore::importer() {
  const Db db = conn();
  if (sqlite3_get_autocommit(db.get()) != 0)
    throw Error(path_ + ": internal error: an import runs inside a transaction");
  return std::make_unique<SqliteImporter>(db);
}

}  // namespace pl::store::detail

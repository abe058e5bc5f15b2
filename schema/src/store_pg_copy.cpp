// The exact copy of a whole store, the PostgreSQL engine's half: every row read verbatim
// (export_rows) and written verbatim (importer) — ids, timestamps, states and publish history
// included. The copy itself (which store to which, the one transaction, the digests) is
// store_copy.cpp's.
#include <cstdint>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "pl/common/error.hpp"
#include "store_copy_rows.hpp"
#include "store_pg.hpp"

namespace pl::store::detail {

namespace {

using Table = RowSink::Table;
using Work = PgStore::Work;

// Rows of the tables read by id a page at a time: a result of libpq is held whole in memory.
constexpr int kPageRows = 5000;

std::int64_t rows_of(Work& w, const char* table) {
  return w.exec1(std::string("SELECT count(*) FROM ") + table)[0].as<std::int64_t>();
}

// The copy's row readers (store_copy_rows.hpp) over a row of a PostgreSQL result.
class CopyRow : public PgRow {
 public:
  CopyRow(const PgStore& store, const pqxx::row& row, const char* table) : PgRow(store, row, table), store_(store), row_(row) {}
  std::optional<std::string> opt_timestamp(int col, const char* column) const {
    if (row_[col].is_null()) return std::nullopt;
    return timestamp(col, column);
  }
  TileRecord tile(int first) const { return read_pg_tile(store_, row_, first); }

 private:
  const PgStore& store_;
  const pqxx::row row_;  // a handle sharing the result, as PgRow's
};

// Runs `sql` (on `table`; its $1 the last id read, its rows ordered by id and LIMITed to `rows`)
// page by page, handing each row, as `read` reads it, to `put`.
template <typename Read, typename Put>
void by_pages(const PgStore& store, Work& w, const char* table, const std::string& sql, Read read, Put put,
              int rows = kPageRows) {
  std::int64_t after = std::numeric_limits<std::int64_t>::min();
  for (;;) {
    const pqxx::result r = w.exec_params(sql, after);
    for (const auto& row : r) {
      const auto value = read(CopyRow(store, row, table));
      after = value.id;
      put(value);
    }
    if (r.size() < static_cast<std::size_t>(rows)) return;
  }
}

// Hands out the rows of a table whose keys and sizes are `sizes` (column 0 the key, 1 the size, in
// key order) in batches of at most kCopyBatchBytes (one row when it is larger): fetch(i, j) reads
// and hands out rows i to j - 1, the keys from sizes[i] to sizes[j - 1].
template <typename Fetch>
void by_batches(const PgStore& store, const pqxx::result& sizes, const char* table, Fetch fetch) {
  std::size_t i = 0;
  while (i < sizes.size()) {
    std::size_t j = i, batch = 0;
    while (j < sizes.size()) {
      const std::size_t n = static_cast<std::size_t>(PgRow(store, sizes[j], table).integer(1, "size", 0));
      if (j > i && batch + n > kCopyBatchBytes) break;
      batch += n;
      ++j;
    }
    fetch(i, j);
    i = j;
  }
}

}  // namespace

// ---- reading ---------------------------------------------------------------------------------------

void PgStore::export_rows(RowSink& out) const {
  guarded([&] {
    Work w(connection());
    // One snapshot for every table (REPEATABLE READ), unless the connection's own transaction is
    // open: the importer's, whose rows are read back before it commits.
    const bool own = !in_transaction();
    if (own) w.exec("BEGIN ISOLATION LEVEL REPEATABLE READ, READ ONLY");
    try {
      using namespace copy_rows;
      const std::string page = " ORDER BY id LIMIT " + std::to_string(kPageRows);
      out.begin_table(Table::Maps, rows_of(w, "maps"));
      by_pages(*this, w, "maps",
               "SELECT id, name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size, current_version, " PL_PG_TIMESTAMP(
                   "created") " FROM maps WHERE id > $1" + page,
               map_row<CopyRow>, [&](const MapRow& m) { out.map(m); });
      out.begin_table(Table::Versions, rows_of(w, "versions"));
      by_pages(*this, w, "versions",
               "SELECT id, map_id, number, parent, state, " PL_PG_TIMESTAMP("created") ", note, " PL_PG_TIMESTAMP(
                   "published") ", replaces FROM versions WHERE id > $1" + page,
               version_row<CopyRow>, [&](const VersionRow& v) { out.version(v); });
      // Blobs: their sizes first, then the bytes in batches of at most kCopyBatchBytes (one blob
      // when it is larger), by ranges of hashes in byte order (COLLATE "C", as SQLite sorts them).
      {
        const pqxx::result sizes = w.exec("SELECT hash, size FROM blobs ORDER BY hash COLLATE \"C\"");
        out.begin_table(Table::Blobs, static_cast<std::int64_t>(sizes.size()));
        by_batches(*this, sizes, "blobs", [&](std::size_t i, std::size_t j) {
          const std::string first = sizes[i][0].as<std::string>(), last = sizes[j - 1][0].as<std::string>();
          const pqxx::result r = w.exec_params(
              "SELECT hash, bytes, size FROM blobs WHERE hash COLLATE \"C\" >= $1 AND hash COLLATE \"C\" <= $2 "
              "ORDER BY hash COLLATE \"C\"",
              first, last);
          if (r.size() != j - i) damaged("blobs changed while they were read");
          for (const auto& row : r) out.blob(blob_row(CopyRow(*this, row, "blobs")));
        });
      }
      out.begin_table(Table::Tiles, rows_of(w, "tiles"));
      by_pages(*this, w, "tiles",
               "SELECT id, map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, max_z "
               "FROM tiles WHERE id > $1" + page,
               tile_row<CopyRow>, [&](const TileRow& t) { out.tile(t); });
      // Places (up to 64 MiB each): one row a page.
      out.begin_table(Table::Places, rows_of(w, "places"));
      by_pages(
          *this, w, "places", "SELECT id, map_id, version, hash, bytes, size FROM places WHERE id > $1 ORDER BY id LIMIT 1",
          places_row<CopyRow>, [&](const PlacesRow& p) { out.places(p); }, 1);
      out.begin_table(Table::Signatures, rows_of(w, "signatures"));
      by_pages(*this, w, "signatures",
               "SELECT id, map_id, version, public_key, signature, " PL_PG_TIMESTAMP("signed") " FROM signatures "
               "WHERE id > $1" + page,
               signature_row<CopyRow>, [&](const SignatureRow& s) { out.signature(s); });
      out.begin_table(Table::Tokens, rows_of(w, "tokens"));
      by_pages(*this, w, "tokens",
               "SELECT id, hash, role, note, " PL_PG_TIMESTAMP("created") ", " PL_PG_TIMESTAMP("revoked") " FROM tokens "
               "WHERE id > $1" + page,
               token_row<CopyRow>, [&](const TokenRow& t) { out.token(t); });
      out.begin_table(Table::UploadLog, rows_of(w, "upload_log"));
      by_pages(*this, w, "upload_log",
               "SELECT id, " PL_PG_TIMESTAMP("at") ", map, version, action, detail, who FROM upload_log "
               "WHERE id > $1" + page,
               log_row<CopyRow>, [&](const LogRow& e) { out.log(e); });
      // Change reports (up to 32 MiB each): as the blobs, their sizes first, then the rows in
      // batches of ids.
      {
        const pqxx::result sizes = w.exec("SELECT id, size FROM change_reports ORDER BY id");
        out.begin_table(Table::ChangeReports, static_cast<std::int64_t>(sizes.size()));
        by_batches(*this, sizes, "change_reports", [&](std::size_t i, std::size_t j) {
          const pqxx::result r = w.exec_params(
              "SELECT id, version, vehicle, drive, start_s, end_s, hash, size, who, map_id, body, " PL_PG_TIMESTAMP(
                  "received") " FROM change_reports WHERE id >= $1 AND id <= $2 ORDER BY id",
              sizes[i][0].as<std::int64_t>(), sizes[j - 1][0].as<std::int64_t>());
          if (r.size() != j - i) damaged("change reports changed while they were read");
          for (const auto& row : r) out.report(change_report_row(CopyRow(*this, row, "change_reports")));
        });
      }
      if (own) w.exec("COMMIT");
    } catch (...) {
      if (own) {
        try {
          w.exec("ROLLBACK");
        } catch (...) {
          // The connection is gone, and the read transaction with it.
        }
      }
      throw;
    }
  });
}

StoreContent PgStore::content() const {
  return one_statement([&](Work& w) {
    const pqxx::row r = w.exec1(
        "SELECT (SELECT count(*) FROM maps), (SELECT count(*) FROM blobs), (SELECT count(*) FROM tokens), "
        "(SELECT count(*) FROM upload_log)");
    StoreContent c;
    c.maps = r[0].as<std::int64_t>();
    c.blobs = r[1].as<std::int64_t>();
    c.tokens = r[2].as<std::int64_t>();
    c.log_entries = r[3].as<std::int64_t>();
    return c;
  });
}

// ---- writing ---------------------------------------------------------------------------------------

namespace {

// Rows go in as they were, with their ids, in an order the schema's triggers accept as they stand
// for every writer (none is dropped or disabled, not even for this transaction; `SET
// session_replication_role = replica` would also switch off the foreign keys):
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
// The ids are GENERATED ALWAYS: OVERRIDING SYSTEM VALUE gives each row its own, and finish() moves
// every identity sequence past the largest id, so that later rows get new ids.
class PgImporter final : public RowSink {
 public:
  explicit PgImporter(PgStore& store) : store_(store) {}

  void map(const MapRow& m) override {
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO maps (id, name, origin_lat, origin_lon, origin_alt, tile_size, voxel_size, current_version, "
          "created) OVERRIDING SYSTEM VALUE VALUES ($1, $2, $3::float8, $4::float8, $5::float8, $6::float8, "
          "$7::float8, NULL, $8::timestamptz)",
          m.id, m.name, pg_double(m.origin_lat), pg_double(m.origin_lon), pg_double(m.origin_alt),
          pg_double(m.tile_size), pg_double(m.voxel_size), m.created);
    });
    if (m.current_version) current_[m.id] = *m.current_version;
  }

  void version(const VersionRow& v) override {
    store_.require_text(v.note, "note");
    const auto parent = pg_opt_int(v.parent);
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO versions (id, map_id, number, parent, state, created, note, published, replaces) "
          "OVERRIDING SYSTEM VALUE VALUES ($1, $2, $3, $4, 'staged', $5::timestamptz, $6, NULL, NULL)",
          v.id, v.map_id, v.number, pg_opt(parent), v.created, v.note);
    });
    history_.push_back(v);
  }

  void blob(const BlobRow& b) override {
    const pqxx::binarystring bytes(b.bytes.data(), b.bytes.size());
    run([&](Work& w) {
      w.exec_params("INSERT INTO blobs (hash, bytes, size) VALUES ($1, $2, $3)", b.hash, bytes,
                    static_cast<std::int64_t>(b.bytes.size()));
    });
  }

  void tile(const TileRow& t) override {
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO tiles (id, map_id, version, tx, ty, hash, points, bytes, min_x, min_y, min_z, max_x, max_y, "
          "max_z) OVERRIDING SYSTEM VALUE VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9::float8, $10::float8, "
          "$11::float8, $12::float8, $13::float8, $14::float8)",
          t.id, t.map_id, t.version, t.tx, t.ty, t.hash, t.points, t.bytes, pg_double(t.min_x), pg_double(t.min_y),
          pg_double(t.min_z), pg_double(t.max_x), pg_double(t.max_y), pg_double(t.max_z));
    });
  }

  void places(const PlacesRow& p) override {
    const pqxx::binarystring bytes(p.bytes.data(), p.bytes.size());
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO places (id, map_id, version, hash, bytes, size) OVERRIDING SYSTEM VALUE "
          "VALUES ($1, $2, $3, $4, $5, $6)",
          p.id, p.map_id, p.version, p.hash, bytes, static_cast<std::int64_t>(p.bytes.size()));
    });
  }

  void signature(const SignatureRow& s) override {
    const pqxx::binarystring key(s.public_key.data(), s.public_key.size()),
        sig(s.signature.data(), s.signature.size());
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO signatures (id, map_id, version, public_key, signature, signed) OVERRIDING SYSTEM VALUE "
          "VALUES ($1, $2, $3, $4, $5, $6::timestamptz)",
          s.id, s.map_id, s.version, key, sig, s.signed_at);
    });
  }

  void token(const TokenRow& t) override {
    store_.require_text(t.note, "token note");
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO tokens (id, hash, role, note, created, revoked) OVERRIDING SYSTEM VALUE "
          "VALUES ($1, $2, $3, $4, $5::timestamptz, $6::timestamptz)",
          t.id, t.hash, std::string(role_name(t.role)), t.note, t.created, pg_opt(t.revoked));
    });
  }

  void log(const LogRow& e) override {
    store_.require_text(e.map, "upload log map");
    store_.require_text(e.action, "upload log action");
    store_.require_text(e.detail, "upload log detail");
    store_.require_text(e.who, "upload log who");
    const auto version = pg_opt_int(e.version);
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO upload_log (id, at, map, version, action, detail, who) OVERRIDING SYSTEM VALUE "
          "VALUES ($1, $2::timestamptz, $3, $4, $5, $6, $7)",
          e.id, e.at, e.map, pg_opt(version), e.action, e.detail, e.who);
    });
  }

  void report(const ReportRow& r) override {
    store_.require_text(r.who, "change report's sender (who)");
    const pqxx::binarystring body(r.body.data(), r.body.size());
    run([&](Work& w) {
      w.exec_params(
          "INSERT INTO change_reports (id, map_id, version, vehicle, drive, start_s, end_s, hash, body, size, received, "
          "who) OVERRIDING SYSTEM VALUE VALUES ($1, $2, $3, $4, $5, $6::float8, $7::float8, $8, $9, $10, "
          "$11::timestamptz, $12)",
          r.id, r.map_id, r.version, r.vehicle, r.drive, pg_double(r.start), pg_double(r.end), r.hash, body,
          static_cast<std::int64_t>(r.body.size()), r.received, r.who);
    });
  }

  void finish() override {
    run([&](Work& w) {
      for (const VersionRow& v : history_) {
        if (!v.published && !v.replaces) continue;
        const auto replaces = pg_opt_int(v.replaces);
        w.exec_params(
            "UPDATE versions SET published = $3::timestamptz, replaces = $4 WHERE map_id = $1 AND number = $2",
            v.map_id, v.number, pg_opt(v.published), pg_opt(replaces));
      }
      auto set_state = [&](const VersionRow& v, const char* state) {
        w.exec_params("UPDATE versions SET state = $3 WHERE map_id = $1 AND number = $2", v.map_id, v.number,
                      std::string(state));
      };
      for (const VersionRow& v : history_) {
        if (v.state != VersionState::Retired) continue;
        set_state(v, "published");
        set_state(v, "retired");
      }
      for (const VersionRow& v : history_)
        if (v.state == VersionState::Published) set_state(v, "published");
      for (const auto& [map_id, number] : current_)
        w.exec_params("UPDATE maps SET current_version = $2 WHERE id = $1", map_id, number);
      // Table names are this file's own, never outside values.
      for (const char* table : {"maps", "versions", "tiles", "places", "signatures", "tokens", "upload_log", "change_reports"})
        w.exec(std::string("SELECT setval(pg_get_serial_sequence('") + table + "', 'id'), coalesce(max(id), 0) + 1, false) FROM " +
               table);
    });
  }

 private:
  // Every write in the Store::Transaction the copy opened: a failure fails the whole copy (and is
  // rolled back with it), so no savepoint is needed per row.
  template <typename F>
  void run(F&& f) {
    store_.guarded([&] {
      Work w(store_.connection());
      f(w);
    });
  }

  PgStore& store_;
  std::vector<VersionRow> history_;  // small: no bytes
  std::map<std::int64_t, std::int64_t> current_;
};

}  // namespace

std::unique_ptr<RowSink> PgStore::importer() {
  if (!in_transaction()) throw Error(name_ + ": internal error: an import runs inside a transaction");
  // Other writers wait until the copy commits (readers go on): nothing comes between the check
  // that the store is empty and the rows written into it.
  guarded([&] {
    Work w(connection());
    w.exec("LOCK TABLE maps, versions, blobs, tiles, places, signatures, tokens, upload_log, change_reports IN EXCLUSIVE "
           "MODE");
  });
  return std::make_unique<PgImporter>(*this);
}

}  // namespace pl::store::detail

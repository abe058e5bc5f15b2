// The engine behind a Store: SQLite (store_internal.hpp's SqliteStore, a file path) or PostgreSQL
// (store_pg.hpp's PgStore, a postgresql:// URL). Store's public calls forward here one to one; every promise store.hpp makes
// (arguments checked, messages, ordering, unknown maps, staged-only writes, hashes checked on read,
// the append-only log) is each backend's to keep, and tests/schema/test_store_*.cpp holds both to it.
// Private to pl_schema.
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"

namespace pl::store::detail {

// The largest tile either engine stores: the SQLite connection's value limit, so that a store moves
// between the engines (PostgreSQL's own limit for a bytea is 1 GB).
inline constexpr std::size_t kMaxTileBytes = std::size_t{256} << 20;
// The largest change report the store keeps: what the report's parser takes at most
// (ChangeReportLimits::max_bytes, checked against it in store_facade.cpp).
inline constexpr std::size_t kMaxReportBytes = std::size_t{32} << 20;
// How many bytes of blobs an export reads from PostgreSQL at once (more when one blob is larger).
inline constexpr std::size_t kCopyBatchBytes = std::size_t{32} << 20;

// ---- rows of a whole store, as the exact copy (pl/schema/store_copy.hpp) moves them ----------------
// Every column of every table, ids and timestamps included, in the form both engines read and
// write: integers, doubles, text, bytes, and timestamps as store.hpp writes them (UTC ISO 8601 to
// the millisecond: SQLite keeps no more, PostgreSQL's microseconds are not copied).

struct MapRow {
  std::int64_t id = 0;
  std::string name;
  double origin_lat = 0, origin_lon = 0, origin_alt = 0, tile_size = 0, voxel_size = 0;
  std::optional<std::int64_t> current_version;
  std::string created;
};

struct VersionRow {
  std::int64_t id = 0, map_id = 0, number = 0;
  std::optional<std::int64_t> parent;
  VersionState state = VersionState::Staged;
  std::string created, note;
  std::optional<std::string> published;  // when first published
  // Rollback's step: the version current when it was published; for a version published by a
  // rollback, the step of the version whose content it restores (so that rollbacks walk back).
  std::optional<std::int64_t> replaces;
};

struct BlobRow {
  std::string hash, bytes;  // bytes checked against the hash by the reader
};

struct TileRow {
  std::int64_t id = 0, map_id = 0, version = 0, tx = 0, ty = 0;
  std::string hash;
  std::int64_t points = 0, bytes = 0;
  double min_x = 0, min_y = 0, min_z = 0, max_x = 0, max_y = 0, max_z = 0;
};

struct PlacesRow {
  std::int64_t id = 0, map_id = 0, version = 0;
  std::string hash, bytes;  // bytes checked against the hash by the reader
};

struct SignatureRow {
  std::int64_t id = 0, map_id = 0, version = 0;
  std::string public_key, signature, signed_at;
};

struct TokenRow {
  std::int64_t id = 0;
  std::string hash;  // SHA-256 of the token, as stored
  Role role = Role::Read;
  std::string note, created;
  std::optional<std::string> revoked;
};

struct LogRow {
  std::int64_t id = 0;
  std::string at, map;
  std::optional<std::int64_t> version;
  std::string action, detail, who;
};

struct ReportRow {
  std::int64_t id = 0, map_id = 0, version = 0;
  std::string vehicle, drive;
  double start = 0, end = 0;
  std::string hash, body;  // body checked against the hash by the reader
  std::string received, who;
};

// Where a store's rows go, table by table in this order (each announced by begin_table with its
// number of rows), each table in key order: its id, blobs by hash. Blobs, places and change reports
// come one at a time, so that a store larger than memory passes through. Change reports (schema 5)
// come last, after the upload log: the tables before them keep the numbers they had.
class RowSink {
 public:
  enum class Table { Maps, Versions, Blobs, Tiles, Places, Signatures, Tokens, UploadLog, ChangeReports };
  virtual ~RowSink() = default;
  virtual void begin_table(Table, std::int64_t /*rows*/) {}
  virtual void map(const MapRow&) = 0;
  virtual void version(const VersionRow&) = 0;
  virtual void blob(const BlobRow&) = 0;
  virtual void tile(const TileRow&) = 0;
  virtual void places(const PlacesRow&) = 0;
  virtual void signature(const SignatureRow&) = 0;
  virtual void token(const TokenRow&) = 0;
  virtual void log(const LogRow&) = 0;
  virtual void report(const ReportRow&) = 0;
  // After the last row: what the writer left for the end (an importer: states, current versions).
  virtual void finish() {}
};

// The damaged error of export_rows for a blob, places or change report whose bytes do not hash to
// their hash (or whose size column disagrees), told apart from every other failure by
// checked_digest: a store whose bytes changed is reported damaged, as integrity_ok reports it, not
// failed.
struct DamagedBytes : Error {
  using Error::Error;
};

// What an importer refuses to write into: a store holding any map, blob, token or log entry.
struct StoreContent {
  std::int64_t maps = 0, blobs = 0, tokens = 0, log_entries = 0;
  bool empty() const { return maps == 0 && blobs == 0 && tokens == 0 && log_entries == 0; }
};

// The engines get arguments Store has checked already (names, origins, sizes, bounds, empty
// values: store_facade.cpp); what they check themselves is what only they know (the text
// PostgreSQL takes, states, existence).
class StoreBackend {
 public:
  virtual ~StoreBackend() = default;

  // The name messages start with: the file path, or the URL without its password.
  virtual const std::string& path() const = 0;
  virtual int schema_version() const = 0;

  virtual MapInfo create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size) = 0;
  virtual std::optional<MapInfo> find_map(const std::string& name) const = 0;
  virtual std::vector<MapInfo> list_maps() const = 0;

  virtual VersionInfo create_version(const std::string& map, std::optional<std::int64_t> parent, const std::string& note) = 0;
  virtual std::optional<VersionInfo> find_version(const std::string& map, std::int64_t number) const = 0;
  virtual std::vector<VersionInfo> list_versions(const std::string& map) const = 0;
  // With `only_if_current`: publishes only while the map's current version is *only_if_current (an
  // empty optional inside: none published yet); returns false, changing nothing, otherwise. With
  // `restores` (a rollback), the new version's `replaces` is that version's, not the old current.
  virtual bool publish(const std::string& map, std::int64_t number,
                       const std::optional<std::optional<std::int64_t>>& only_if_current,
                       std::optional<std::int64_t> restores) = 0;
  // The retired version a rollback restores: the current one's `replaces`. Throws when there is none.
  virtual std::int64_t rollback_target(const std::string& map) const = 0;

  virtual TileRecord put_tile(const std::string& map, std::int64_t version, const TileKey& key, std::string_view draco_bytes,
                              std::int64_t points, double min_x, double min_y, double min_z, double max_x, double max_y,
                              double max_z) = 0;
  virtual bool delete_tile(const std::string& map, std::int64_t version, const TileKey& key) = 0;
  virtual std::optional<TileRecord> find_tile(const std::string& map, std::int64_t version, const TileKey& key) const = 0;
  virtual std::vector<TileRecord> list_tiles(const std::string& map, std::int64_t version) const = 0;
  virtual std::vector<TileRecord> tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                               double max_x, double max_y) const = 0;
  virtual std::optional<std::string> blob(const std::string& hash) const = 0;
  virtual bool has_blob(const std::string& hash) const = 0;

  virtual void put_places(const std::string& map, std::int64_t version, std::string_view bytes) = 0;
  virtual bool delete_places(const std::string& map, std::int64_t version) = 0;
  virtual std::optional<std::string> places(const std::string& map, std::int64_t version) const = 0;
  virtual std::optional<std::string> places_hash(const std::string& map, std::int64_t version) const = 0;

  virtual void put_signature(const std::string& map, std::int64_t version, std::string_view public_key,
                             std::string_view signature) = 0;
  virtual std::optional<Store::Signature> signature(const std::string& map, std::int64_t version) const = 0;

  virtual std::int64_t add_token(const std::string& token, Role role, const std::string& note) = 0;
  // The row whose hash is `hash` (revoked or not), with the hash as stored: Store compares it.
  virtual std::optional<std::pair<Store::TokenInfo, std::string>> token_by_hash(const std::string& hash) const = 0;
  virtual bool revoke_token(std::int64_t id) = 0;
  virtual std::vector<Store::TokenInfo> list_tokens() const = 0;

  virtual void log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                          const std::string& detail, const std::string& who) = 0;
  virtual std::vector<Store::LogEntry> upload_log(const std::string& map) const = 0;

  // Change reports: Store has checked the ids, span, body size and who; `hash` is the body's.
  virtual Store::ReportPut put_report(const std::string& map, std::int64_t version, const std::string& vehicle,
                                      const std::string& drive, double start, double end, std::string_view body,
                                      const std::string& hash, const std::string& who) = 0;
  virtual std::vector<Store::ReportInfo> list_reports(const std::string& map, std::optional<std::int64_t> version) const = 0;
  virtual std::optional<std::string> report_body(const std::string& map, std::int64_t id) const = 0;
  // `received_before` is a timestamp as the store writes them (Store has checked it).
  virtual std::int64_t delete_reports(const std::string& map, const std::string& received_before) = 0;

  // Store::Transaction: begin returns whether it is nested in an open one (a savepoint);
  // rollback_quietly never throws (it runs in a destructor).
  virtual bool begin_transaction() = 0;
  virtual void commit_transaction(bool nested) = 0;
  virtual void rollback_transaction_quietly(bool nested) noexcept = 0;

  // Whether the connection can still be used: false once a PostgreSQL server went away under it
  // (a restart, a network cut); a SQLite file's connection always can.
  virtual bool usable() const { return true; }

  virtual std::int64_t database_bytes() const = 0;
  // Store::integrity_ok with `hash_bytes`; without it, every check but the hashes and sizes of blobs,
  // places and change reports, for a caller that reads every blob through export_rows anyway, which
  // checks them (DamagedBytes): the copy's read-back, checked_digest. Each blob is then read once,
  // not twice.
  virtual bool integrity_ok(bool hash_bytes) const = 0;

  // ---- the exact copy of a whole store (store_copy.cpp) ----
  // Hands every row to `out` (RowSink says in which order), read from one snapshot: a read
  // transaction of its own, or the transaction this connection has open (an importer's, to verify
  // what it wrote before committing). Every value is checked as the other reads check it
  // (store_copy_rows.hpp); a blob, places or change report whose bytes do not hash to their hash is
  // the damaged error, a DamagedBytes. Blob, places and report bytes are read a few at a time
  // (PostgreSQL: batches of at most kCopyBatchBytes), never all at once.
  virtual void export_rows(RowSink& out) const = 0;
  // What the store holds of what makes it non-empty (StoreContent).
  virtual StoreContent content() const = 0;
  // Inside an open transaction (begin_transaction): the writer of rows exported from another store,
  // verbatim (ids, timestamps, states, publish history), into this one, which the caller then
  // finds empty (content(); on PostgreSQL the importer has locked the tables against other writers
  // by then). The rows must come in RowSink's order and end with finish(); nothing is committed by
  // it. The engines' importers say how the schema's triggers accept the rows as they stand.
  virtual std::unique_ptr<RowSink> importer() = 0;
};

std::unique_ptr<StoreBackend> open_sqlite(const std::string& path, bool create);
// The URL as messages show it: a password in it as *** (store_pg.cpp).
std::string redact_url(const std::string& url);
// `url` is postgresql://... or postgres://... (store::is_postgres_url)
std::unique_ptr<StoreBackend> open_postgres(const std::string& url, bool create);

}  // namespace pl::store::detail

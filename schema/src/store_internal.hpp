// What store.cpp, store_tiles.cpp, store_places.cpp and store_reports.cpp share: the file's identity, the row readers
// and lookups of maps, versions and tiles. Private to pl_schema.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "pl/schema/detail/sqlite.hpp"
#include "pl/schema/store.hpp"
#include "store_backend.hpp"

namespace pl::store::detail {

inline constexpr std::int64_t kMaxInt64 = std::numeric_limits<std::int64_t>::max();
inline constexpr std::int64_t kMinKey = std::numeric_limits<std::int32_t>::min(), kMaxKey = std::numeric_limits<std::int32_t>::max();
inline constexpr const char* kTileColumns =
    "SELECT t.tx, t.ty, t.hash, t.points, t.bytes, t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z "
    "FROM tiles AS t ";

std::int64_t pragma_int(const sqlite::Db& db, const char* sql);
std::string num(std::int64_t v);
std::string read_timestamp(const sqlite::Row& row, int col, const char* column);
VersionState read_state(const sqlite::Row& row, int col, const char* column);

std::optional<std::int64_t> find_map_id(const sqlite::Db& db, const std::string& name);
std::int64_t require_map(const sqlite::Db& db, const std::string& name);  // throws for an unknown map
// The version's state; throws "PATH: map MAP has no version N" when there is no such version.
VersionState require_version(const sqlite::Db& db, const std::string& map, std::int64_t map_id, std::int64_t number);
// Throws unless the version exists and is staged (writes of tiles and places go to staged versions
// only); `what` names what the caller writes in the message.
void require_staged(const sqlite::Db& db, const std::string& map, std::int64_t map_id, std::int64_t number,
                    const char* what = "tiles");

// A row of kTileColumns, checked; `first`: the column its tx is in (the exact copy's rows have
// their ids before it).
TileRecord read_tile(const sqlite::Stmt& st, int first = 0);
std::optional<std::string> tile_hash(const sqlite::Db& db, std::int64_t map_id, std::int64_t version, const TileKey& key);
void drop_blob_if_unused(const sqlite::Db& db, const std::string& hash);

// The SQLite engine: one connection to one file, with the statements it prepared kept for reuse.
class SqliteStore final : public StoreBackend {
 public:
  explicit SqliteStore(std::string path);
  ~SqliteStore() override;
  SqliteStore(const SqliteStore&) = delete;
  SqliteStore& operator=(const SqliteStore&) = delete;

  const std::string& path() const override { return path_; }
  int schema_version() const override;
  MapInfo create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size) override;
  std::optional<MapInfo> find_map(const std::string& name) const override;
  std::vector<MapInfo> list_maps() const override;
  VersionInfo create_version(const std::string& map, std::optional<std::int64_t> parent, const std::string& note) override;
  std::optional<VersionInfo> find_version(const std::string& map, std::int64_t number) const override;
  std::vector<VersionInfo> list_versions(const std::string& map) const override;
  bool publish(const std::string& map, std::int64_t number,
               const std::optional<std::optional<std::int64_t>>& only_if_current,
               std::optional<std::int64_t> restores) override;
  std::int64_t rollback_target(const std::string& map) const override;
  TileRecord put_tile(const std::string& map, std::int64_t version, const TileKey& key, std::string_view draco_bytes,
                      std::int64_t points, double min_x, double min_y, double min_z, double max_x, double max_y,
                      double max_z) override;
  bool delete_tile(const std::string& map, std::int64_t version, const TileKey& key) override;
  std::optional<TileRecord> find_tile(const std::string& map, std::int64_t version, const TileKey& key) const override;
  std::vector<TileRecord> list_tiles(const std::string& map, std::int64_t version) const override;
  std::vector<TileRecord> tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                       double max_x, double max_y) const override;
  std::optional<std::string> blob(const std::string& hash) const override;
  bool has_blob(const std::string& hash) const override;
  void put_places(const std::string& map, std::int64_t version, std::string_view bytes) override;
  bool delete_places(const std::string& map, std::int64_t version) override;
  std::optional<std::string> places(const std::string& map, std::int64_t version) const override;
  std::optional<std::string> places_hash(const std::string& map, std::int64_t version) const override;
  void put_signature(const std::string& map, std::int64_t version, std::string_view public_key,
                     std::string_view signature) override;
  std::optional<Store::Signature> signature(const std::string& map, std::int64_t version) const override;
  std::int64_t add_token(const std::string& token, Role role, const std::string& note) override;
  std::optional<std::pair<Store::TokenInfo, std::string>> token_by_hash(const std::string& hash) const override;
  bool revoke_token(std::int64_t id) override;
  std::vector<Store::TokenInfo> list_tokens() const override;
  void log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                  const std::string& detail, const std::string& who) override;
  std::vector<Store::LogEntry> upload_log(const std::string& map) const override;
  // Change reports (store_reports.cpp).
  Store::ReportPut put_report(const std::string& map, std::int64_t version, const std::string& vehicle,
                              const std::string& drive, double start, double end, std::string_view body,
                              const std::string& hash, const std::string& who) override;
  std::vector<Store::ReportInfo> list_reports(const std::string& map, std::optional<std::int64_t> version) const override;
  std::optional<std::string> report_body(const std::string& map, std::int64_t id) const override;
  std::int64_t delete_reports(const std::string& map, const std::string& received_before) override;
  bool begin_transaction() override;
  void commit_transaction(bool nested) override;
  void rollback_transaction_quietly(bool nested) noexcept override;
  std::int64_t database_bytes() const override;
  bool integrity_ok(bool hash_bytes) const override;
  // The exact copy (store_copy_sqlite.cpp / store_pg_copy.cpp).
  void export_rows(RowSink& out) const override;
  StoreContent content() const override;
  std::unique_ptr<RowSink> importer() override;

 private:
  friend std::unique_ptr<StoreBackend> open_sqlite(const std::string& path, bool create);
  sqlite::Db conn() const;  // the connection, with the file's name and the kept statements

  std::string path_;
  void* db_ = nullptr;  // sqlite3*
  std::unique_ptr<sqlite::StmtCache> stmts_;
};

}  // namespace pl::store::detail

namespace pl::store {

// The SQLite toolkit names both halves of the store use.
using sqlite::damaged;
using sqlite::Db;
using sqlite::exec;
using sqlite::plain;
using sqlite::Row;
using sqlite::Stmt;
using sqlite::WriteScope;

}  // namespace pl::store

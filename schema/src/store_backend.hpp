// The engine behind a Store: SQLite (store_internal.hpp's SqliteStore, a file path) or PostgreSQL
// (store_pg.hpp's PgStore, a postgresql:// URL). Store's public calls forward here one to one; every promise store.hpp makes
// (arguments checked, messages, ordering, unknown maps, staged-only writes, hashes checked on read,
// the append-only log) is each backend's to keep, and tests/schema/test_store.cpp holds both to it.
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

#include "pl/schema/store.hpp"

namespace pl::store::detail {

// The largest tile either engine stores: the SQLite connection's value limit, so that a store moves
// between the engines (PostgreSQL's own limit for a bytea is 1 GB).
inline constexpr std::size_t kMaxTileBytes = std::size_t{256} << 20;

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
  // empty optional inside: none published yet); returns false, changing nothing, otherwise.
  virtual bool publish(const std::string& map, std::int64_t number,
                       const std::optional<std::optional<std::int64_t>>& only_if_current) = 0;
  virtual std::int64_t rollback(const std::string& map) = 0;

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

  // Store::Transaction: begin returns whether it is nested in an open one (a savepoint);
  // rollback_quietly never throws (it runs in a destructor).
  virtual bool begin_transaction() = 0;
  virtual void commit_transaction(bool nested) = 0;
  virtual void rollback_transaction_quietly(bool nested) noexcept = 0;

  // Whether the connection can still be used: false once a PostgreSQL server went away under it
  // (a restart, a network cut); a SQLite file's connection always can.
  virtual bool usable() const { return true; }

  virtual std::int64_t database_bytes() const = 0;
  virtual bool integrity_ok() const = 0;
};

std::unique_ptr<StoreBackend> open_sqlite(const std::string& path, bool create);
// The URL as messages show it: a password in it as *** (store_pg.cpp).
std::string redact_url(const std::string& url);
// `url` is postgresql://... or postgres://... (store::is_postgres_url)
std::unique_ptr<StoreBackend> open_postgres(const std::string& url, bool create);

}  // namespace pl::store::detail

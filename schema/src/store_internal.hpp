// What store.cpp, store_tiles.cpp and store_places.cpp share: the file's identity, the row readers
// and lookups of maps, versions and tiles. Private to pl_schema.
#pragma once

#include <cstdint>
#include <limits>
#include <optional>
#include <string>

#include "pl/schema/detail/sqlite.hpp"
#include "pl/schema/store.hpp"

namespace pl::store::detail {

inline constexpr std::int64_t kMaxInt64 = std::numeric_limits<std::int64_t>::max();
inline constexpr std::int64_t kMinKey = std::numeric_limits<std::int32_t>::min(), kMaxKey = std::numeric_limits<std::int32_t>::max();
inline constexpr const char* kTileColumns =
    "SELECT t.tx, t.ty, t.hash, t.points, t.bytes, t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z "
    "FROM tiles AS t ";

// The connection of a store file, with its name and fixes for messages.
sqlite::Db handle(void* db, const std::string& path);
std::int64_t pragma_int(const sqlite::Db& db, const char* sql);
std::string num(std::int64_t v);
std::string read_timestamp(const sqlite::Row& row, int col, const char* column);

std::optional<std::int64_t> find_map_id(const sqlite::Db& db, const std::string& name);
std::int64_t require_map(const sqlite::Db& db, const std::string& name);  // throws for an unknown map
// Throws unless the version exists and is staged (writes of tiles and places go to staged versions
// only); `what` names what the caller writes in the message.
void require_staged(const sqlite::Db& db, const std::string& map, std::int64_t map_id, std::int64_t number,
                    const char* what = "tiles");

TileRecord read_tile(const sqlite::Stmt& st);  // a row of kTileColumns, checked
std::optional<std::string> tile_hash(const sqlite::Db& db, std::int64_t map_id, std::int64_t version, const TileKey& key);
void drop_blob_if_unused(const sqlite::Db& db, const std::string& hash);

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

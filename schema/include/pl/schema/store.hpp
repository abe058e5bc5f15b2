// The map store: versioned maps of Draco tiles, in one SQLite file (the default: schema/NNN_*.sql,
// migrated by PRAGMA user_version, WAL mode, foreign keys on) or in a PostgreSQL database (a
// postgresql:// URL: schema/pg/NNN_*.sql, the same tables and rules in PostgreSQL's dialect). Both
// keep every promise below. A Store is one connection: open one per thread.
//
// Semantics (the schema is in schema/NNN_*.sql, and schema/pg/NNN_*.sql for PostgreSQL):
// - Every error (the engine's included) is a pl::Error whose message starts with the database path
//   (PATH below: the file, or the URL with its password as ***).
// - Several connections (threads or processes) may use one store. SQLite: WAL lets readers run
//   next to one writer; writers take the write lock up front (BEGIN IMMEDIATE) and wait up to 5 s
//   for it. PostgreSQL: readers never wait; writers to one map take turns (a row lock on the map),
//   writers to different maps run at once. PostgreSQL text (notes, the upload log) must be UTF-8
//   without NUL bytes (an error says so); SQLite keeps any bytes.
// - Unknown maps: the reading calls (find_*, list_*, tiles_in_box, places, places_hash,
//   upload_log) return nothing (std::nullopt or an empty list); the writing calls (create_version,
//   publish, rollback, put_tile, delete_tile, put_places, delete_places) throw pl::Error "PATH:
//   unknown map NAME". An unknown version of a known map is handled the same way. log_upload
//   accepts any map name (attempts on unknown maps are worth logging).
// - Version numbers are 1, 2, ... per map. A version is staged, then published (it becomes the
//   map's current version; the previously current one is retired), and is retired by the next
//   publish. A retired version is never published again: a rollback publishes a new version with
//   the old one's content, so the current version's number only ever grows (vehicles refuse to go
//   back to a lower number than they have verified). Only staged versions accept
//   writes of tiles and places. Readers use MapInfo::current; staged tiles are only seen by asking
//   for that version number explicitly.
// - Timestamps are UTC ISO 8601 with milliseconds and 'Z' ("2024-05-01T10:11:12.345Z").
// - Damaged or crafted files: SQLite's own reports of damage (on any call) and every value that
//   breaks what the schema promises (types, NOT NULL, ranges, names, hashes, states, timestamps, a
//   current version that is not published, a parent that does not exist, a blob or places whose
//   bytes do not hash to their hash) are a pl::Error "PATH: the map store is damaged (WHAT):
//   restore it from a backup, or rebuild it with pl-map". A schema that is not exactly the
//   migrations' own (an extra trigger, a view for a table, a table without its constraints) is
//   refused at open. Damage SQLite only finds in a full check (keys out of order, an index that
//   disagrees with its table) shows in integrity_ok(). Free text (notes, the upload log) is
//   returned as it was stored, byte for byte.
// - Opening writes nothing to a file it refuses. Opening a current WAL store writes nothing at all;
//   a store that open must switch to WAL or migrate is first checked whole (PRAGMA quick_check).
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "pl/common/geo.hpp"
#include "pl/common/tile_key.hpp"

namespace pl::store {

namespace detail {
class StoreBackend;  // the engine: SQLite or PostgreSQL (schema/src/store_backend.hpp)
}

enum class VersionState { Staged, Published, Retired };
const char* state_name(VersionState s);

// Each includes the ones below it. A report token (one per vehicle) reads maps and sends change
// reports; an upload token also writes versions; an admin token also creates maps and manages tokens.
enum class Role { Read = 1, Report = 2, Upload = 3, Admin = 4 };
const char* role_name(Role r);
std::optional<Role> parse_role(std::string_view name);

struct MapInfo {
  std::int64_t id = 0;
  std::string name;
  GeoPoint origin;         // of the map's local ENU frame
  double tile_size = 20.0;  // metres
  double voxel_size = 0.2;  // metres
  std::optional<std::int64_t> current;  // the published version readers see
  std::string created;                  // UTC, ISO 8601
};

struct VersionInfo {
  std::int64_t number = 0;  // 1, 2, ... per map
  std::optional<std::int64_t> parent;
  VersionState state = VersionState::Staged;
  std::string created;  // UTC, ISO 8601
  std::string note;
  std::int64_t tiles = 0, points = 0, bytes = 0;  // totals over the version's tiles
};

struct TileRecord {
  TileKey key;
  std::string hash;  // content hash of the Draco bytes (SHA-256, lowercase hex)
  std::int64_t points = 0;
  std::int64_t bytes = 0;
  double min_x = 0, min_y = 0, min_z = 0, max_x = 0, max_y = 0, max_z = 0;  // the points' box, ENU metres
};

// Whether `db` names a PostgreSQL database (postgresql://... or postgres://...), not a SQLite file.
bool is_postgres_url(std::string_view db);

// What messages and logs call a store: the file's path, or the URL with any password as ***.
std::string display_name(const std::string& db);

// A new bearer token: 32 random bytes (OpenSSL's RAND_bytes), base64url without padding (43 characters).
std::string random_token();

// SHA-256 of bytes, lowercase hex.
std::string content_hash(std::string_view bytes);

class Store {
 public:
  // Opens (creating when `create`) and migrates the database: `db` is a SQLite file path, or a
  // postgresql://USER[:PASSWORD]@HOST[:PORT]/DATABASE URL (postgres:// too) of an existing
  // database. Throws pl::Error naming the file (the URL without its password) and the problem (not
  // a database, newer schema than this build knows, read-only, damaged, unreachable, ...). Without
  // `create` a missing or empty file, or a database without the store's tables, is an error.
  // The pending migrations run in one transaction: all or none.
  static Store open(const std::string& db, bool create = true);
  // The newest schema version (SQLite: PRAGMA user_version; PostgreSQL: the schema_migrations
  // table) this build can migrate to; both engines have the same number of migrations.
  static int latest_schema_version();
  Store(Store&&) noexcept;
  Store& operator=(Store&&) noexcept;
  Store(const Store&) = delete;
  Store& operator=(const Store&) = delete;
  ~Store();

  int schema_version() const;
  const std::string& path() const;  // what messages name: the file, or the URL without its password

  // Maps. create_map throws pl::Error when the name is taken or invalid ([A-Za-z0-9_.-]{1,64}), the
  // origin is not a valid latitude/longitude, or a size is not a positive number. find_map returns
  // nothing for an unknown (or invalid) name; list_maps is ordered by name.
  MapInfo create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size);
  std::optional<MapInfo> find_map(const std::string& name) const;
  std::vector<MapInfo> list_maps() const;

  // Versions. A new version is staged, starts as a copy of its parent's tiles and places (the
  // current version when `parent` is empty; none for the first), and is invisible to readers until
  // published. The tile copy is of the rows only: blobs are shared by content hash; the places are
  // copied whole. The parent may be in any state; an explicit parent that does not exist is an
  // error. list_versions is ordered by number.
  VersionInfo create_version(const std::string& map, std::optional<std::int64_t> parent, const std::string& note);
  std::optional<VersionInfo> find_version(const std::string& map, std::int64_t number) const;
  std::vector<VersionInfo> list_versions(const std::string& map) const;
  // Makes a staged version current in one transaction; the previously current one becomes retired.
  // Throws pl::Error, naming the version and its state, unless the version is staged.
  void publish(const std::string& map, std::int64_t number);
  // publish, on condition that the map's current version is still `expected_current` (empty: none
  // published yet), which uploaders pass as the version's parent: the version they opened from the
  // current one. Returns false, changing nothing, when another version was published meanwhile. The
  // condition is checked under the map's write lock, in publish's transaction: of two uploaders
  // publishing versions opened from the same current one, exactly one wins, whatever the
  // connections or machines. Throws as publish does.
  bool publish_if_current(const std::string& map, std::int64_t number, std::optional<std::int64_t> expected_current);
  // Rolls the map back: publishes a new version (opened by create_version from rollback_target,
  // so it holds that version's tiles and places, blobs shared; never its signature) and returns
  // its number. "Rolled back to" is the version that was current when the current one was
  // published, and a further rollback goes where one from that version would, so repeated
  // rollbacks walk back through the publish history's content. `before_publish(number)` runs on
  // the staged copy just before it is published, in the same transaction (pl-map signs it there).
  // Throws pl::Error when the map has no current version, the current one was its first publish,
  // or another version was published meanwhile; then nothing is left behind.
  std::int64_t rollback(const std::string& map, const std::function<void(std::int64_t)>& before_publish = {});
  // The retired version whose content a rollback restores now; throws as rollback does.
  std::int64_t rollback_target(const std::string& map) const;

  // Tiles of a staged version (throws pl::Error for a published or retired one). put_tile stores the
  // blob once per content hash and is idempotent; the record's hash/bytes are computed here.
  // put_tile replaces the key's record (same row, same id) and requires non-empty bytes, points >= 0
  // and finite bounds with min <= max. A blob that no tile uses any more after put_tile or
  // delete_tile is deleted. delete_tile returns false when the version has no such tile.
  // list_tiles and tiles_in_box are ordered by (tx, ty).
  TileRecord put_tile(const std::string& map, std::int64_t version, const TileKey& key, std::string_view draco_bytes,
                      std::int64_t points, double min_x, double min_y, double min_z, double max_x, double max_y,
                      double max_z);
  bool delete_tile(const std::string& map, std::int64_t version, const TileKey& key);
  std::optional<TileRecord> find_tile(const std::string& map, std::int64_t version, const TileKey& key) const;
  std::vector<TileRecord> list_tiles(const std::string& map, std::int64_t version) const;
  // Tiles whose box intersects the rectangle, through the R*Tree over tile bounds. Boxes are closed:
  // touching edges intersect. An inverted (min > max) or NaN rectangle matches nothing.
  std::vector<TileRecord> tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                       double max_x, double max_y) const;
  // The bytes whose SHA-256 is `hash` (checked: bytes that changed on disk are a damaged error).
  std::optional<std::string> blob(const std::string& hash) const;
  bool has_blob(const std::string& hash) const;

  // Places: one opaque blob per version, the place-recognition descriptors built with the map
  // (their format is the map builder's). put_places and delete_places write a staged version only
  // (pl::Error naming the version and its state otherwise); put_places requires 1 byte to
  // api::kMaxPlacesBytes (64 MiB) and replaces the version's places. delete_places returns false
  // when the version has none. places returns nothing for an unknown map or version or a version
  // without places; its bytes are checked against their SHA-256 (bytes that changed on disk are a
  // damaged error). places_hash is that SHA-256 (lowercase hex) without reading the bytes.
  void put_places(const std::string& map, std::int64_t version, std::string_view bytes);
  bool delete_places(const std::string& map, std::int64_t version);
  std::optional<std::string> places(const std::string& map, std::int64_t version) const;
  std::optional<std::string> places_hash(const std::string& map, std::int64_t version) const;

  // Signatures: at most one a version, the Ed25519 signature of its manifest
  // (pl/schema/signed_manifest.hpp) by the key of whoever publishes it. put_signature writes a
  // staged version only (pl::Error naming the version and its state otherwise) and replaces the
  // version's signature; sign just before publishing, in publish's Transaction, so that no tile
  // changes between. It takes a 32-byte public key and a 64-byte signature; the store does not
  // check that the signature verifies (signed_manifest.hpp does, and the vehicle). signature
  // returns nothing for an unknown map or version or an unsigned version. A new version never
  // inherits its parent's signature.
  struct Signature {
    std::string public_key, signature;  // 32 and 64 bytes
    std::string signed_at;              // UTC, ISO 8601
  };
  void put_signature(const std::string& map, std::int64_t version, std::string_view public_key, std::string_view signature);
  std::optional<Signature> signature(const std::string& map, std::int64_t version) const;

  // Tokens are stored hashed (SHA-256), never in plain. add_token returns the new token's id and
  // throws pl::Error for an empty token or one that is already registered (revoked or not).
  // find_token answers a token in force (not revoked): it is looked up by its SHA-256, whose bytes
  // tell nothing of the token's, and the stored hash is then compared in constant time
  // (CRYPTO_memcmp). check_token is find_token's role. revoke_token takes a token out of force for
  // every connection at once (false: no such id, or revoked already); list_tokens lists them all by
  // id, revoked ones too, never a token itself.
  struct TokenInfo {
    std::int64_t id = 0;
    Role role = Role::Read;
    std::string note, created;           // created: UTC, ISO 8601
    std::optional<std::string> revoked;  // when it was revoked; empty: in force
  };
  std::int64_t add_token(const std::string& token, Role role, const std::string& note);
  std::optional<TokenInfo> find_token(const std::string& token) const;
  std::optional<Role> check_token(const std::string& token) const;
  bool revoke_token(std::int64_t id);
  std::vector<TokenInfo> list_tokens() const;

  // Change reports from the fleet (pl/schema/change_report.hpp), kept as the JSON the vehicle sent,
  // one per (map, vehicle, drive): a report sent again is the same report. put_report stores a
  // report against an existing version of an existing map (pl::Error "PATH: unknown map NAME" or
  // "... has no version N" otherwise) and answers Stored, or AlreadyStored when the same vehicle's
  // drive is stored with the same bytes (nothing written), or Conflict when it is stored with other
  // bytes (nothing written). The body must be 1 byte to 32 MiB (pl::Error otherwise); the store
  // does not parse it (the server does before it calls put_report) but keeps its SHA-256, checked on
  // read like a blob's. Reports are never changed (triggers refuse UPDATE); delete_reports removes a
  // map's reports received before a time (retention) and returns how many. list_reports is ordered
  // by id (the order received); `version` empty: all of the map's.
  struct ReportInfo {
    std::int64_t id = 0;
    std::string map;
    std::int64_t version = 0;
    std::string vehicle, drive;
    double start = 0, end = 0;  // the drive's span, seconds since 1970, as the report says
    std::string hash;           // SHA-256 of the body, lowercase hex
    std::int64_t bytes = 0;
    std::string received, who;  // UTC ISO 8601; who sent it ("token 7", as the upload log names them)
  };
  enum class ReportPut { Stored, AlreadyStored, Conflict };
  ReportPut put_report(const std::string& map, std::int64_t version, const std::string& vehicle, const std::string& drive,
                       double start, double end, std::string_view body, const std::string& who);
  std::vector<ReportInfo> list_reports(const std::string& map, std::optional<std::int64_t> version = std::nullopt) const;
  // The report's JSON (nothing for an unknown id or map); bytes checked against their hash.
  std::optional<std::string> report_body(const std::string& map, std::int64_t id) const;
  std::int64_t delete_reports(const std::string& map, const std::string& received_before);

  // The append-only upload log (triggers refuse UPDATE and DELETE). `action` must not be empty;
  // upload_log(map) lists the map's entries oldest first.
  void log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                  const std::string& detail, const std::string& who);
  struct LogEntry {
    std::int64_t id;
    std::string at, map, action, detail, who;
    std::optional<std::int64_t> version;
  };
  std::vector<LogEntry> upload_log(const std::string& map) const;

  // Groups writes into one transaction (imports of thousands of tiles); rolls back unless committed.
  // SQLite takes the write lock at once (BEGIN IMMEDIATE), PostgreSQL each map's row lock as calls
  // reach it; inside another open Transaction it is a savepoint. Each Store call inside it is all-or-nothing on its own (a failed put_tile leaves the
  // Transaction's earlier writes in place).
  class Transaction {
   public:
    explicit Transaction(Store& store);
    void commit();
    ~Transaction();
    Transaction(const Transaction&) = delete;
    Transaction& operator=(const Transaction&) = delete;

   private:
    Store& store_;
    bool done_ = false;
    bool nested_ = false;  // a SAVEPOINT inside an already open transaction (else BEGIN IMMEDIATE)
  };

  // Whether this connection can still be used: false once the PostgreSQL server it talked to went
  // away (restarted, unreachable): open a new Store then. Always true on SQLite.
  bool usable() const;

  // SQLite: page_count * page_size; PostgreSQL: pg_database_size of the database.
  std::int64_t database_bytes() const;
  // SQLite: PRAGMA integrity_check == "ok", no foreign key violations, the R*Tree is sound and
  // holds exactly one entry (containing the tile's xy box) per tile, and every blob and places
  // hash to their hash. PostgreSQL: every blob and places hash to their hash and the rules the
  // schema states hold. False for a corrupt store. Reads every blob: minutes for a large store.
  bool integrity_ok() const;

 private:
  explicit Store(std::unique_ptr<detail::StoreBackend> impl);
  detail::StoreBackend& impl() const;  // throws pl::Error "map store: used after it was moved from"
  std::unique_ptr<detail::StoreBackend> impl_;
};

// A token file (pl-server --tokens): lines of "ROLE TOKEN", ROLE read, report, upload or admin (blank
// lines and '#' comments skipped). Adds each token to the store, hashed, unless it is in force
// already; one revoked since stays revoked (the file does not bring it back) and is passed to
// `revoked` by its line number. Returns the tokens in force from the file. Throws pl::Error naming
// the file and line of a line that is not ROLE TOKEN.
std::size_t add_token_file(Store& store, const std::string& path, const std::function<void(std::size_t line)>& revoked);

}  // namespace pl::store

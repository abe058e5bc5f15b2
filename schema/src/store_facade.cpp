// Store: the public face of the map store. It picks the engine from the name it is given and
// forwards every call to it (store_backend.hpp); the promises are in store.hpp.
#include <utility>

#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/rand.h>

#include <cmath>

#include "pl/common/error.hpp"
#include "pl/common/text.hpp"
#include "pl/schema/api_rules.hpp"
#include "pl/schema/change_report.hpp"
#include "pl/schema/store.hpp"
#include "report_row.hpp"
#include "store_backend.hpp"

namespace pl::store {

bool is_postgres_url(std::string_view db) {
  return db.rfind("postgresql://", 0) == 0 || db.rfind("postgres://", 0) == 0;
}

#ifndef PL_STORE_POSTGRES
// Until the PostgreSQL engine (store_pg.cpp, which defines PL_STORE_POSTGRES for pl_schema) is built.
std::unique_ptr<detail::StoreBackend> detail::open_postgres(const std::string& url, bool) {
  throw Error(url.substr(0, url.find("://") + 3) + "...: this build of PointLocalization has no PostgreSQL map store");
}
#endif

static_assert(detail::kMaxReportBytes == schema::ChangeReportLimits{}.max_bytes,
              "the store keeps every change report the parser takes, and no larger one");

namespace {

// "2024-05-01T10:11:12.345Z", as the store writes every timestamp, and a real date and time: the
// engines compare it with theirs (SQLite as text, PostgreSQL as a timestamptz), and agree only then.
bool valid_timestamp(const std::string& s) {
  static const char shape[] = "dddd-dd-ddTdd:dd:dd.dddZ";
  if (s.size() != sizeof(shape) - 1) return false;
  for (std::size_t i = 0; i < s.size(); ++i)
    if (shape[i] == 'd' ? !(s[i] >= '0' && s[i] <= '9') : s[i] != shape[i]) return false;
  auto field = [&](std::size_t at, std::size_t n) {
    int v = 0;
    for (std::size_t i = at; i < at + n; ++i) v = 10 * v + (s[i] - '0');
    return v;
  };
  const int year = field(0, 4), month = field(5, 2), day = field(8, 2);
  const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
  static const int days[] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
  return year >= 1 && month >= 1 && month <= 12 && day >= 1 && day <= days[month - 1] + (month == 2 && leap ? 1 : 0) &&
         field(11, 2) <= 23 && field(14, 2) <= 59 && field(17, 2) <= 59;
}

}  // namespace

std::string display_name(const std::string& db) { return is_postgres_url(db) ? detail::redact_url(db) : db; }

std::string random_token() {
  unsigned char bytes[32];
  if (RAND_bytes(bytes, sizeof(bytes)) != 1) throw Error("cannot make a token: OpenSSL's RAND_bytes failed");
  unsigned char b64[64];
  const int n = EVP_EncodeBlock(b64, bytes, sizeof(bytes));
  std::string out(reinterpret_cast<const char*>(b64), static_cast<std::size_t>(n));
  for (auto& c : out) c = c == '+' ? '-' : c == '/' ? '_' : c;  // base64url
  while (!out.empty() && out.back() == '=') out.pop_back();
  return out;
}

Store::Store(std::unique_ptr<detail::StoreBackend> impl) : impl_(std::move(impl)) {}
Store::Store(Store&&) noexcept = default;
Store& Store::operator=(Store&&) noexcept = default;
Store::~Store() = default;

Store Store::open(const std::string& db, bool create) {
  if (db.empty()) throw Error("map store: empty database path");
  return Store(is_postgres_url(db) ? detail::open_postgres(db, create) : detail::open_sqlite(db, create));
}

detail::StoreBackend& Store::impl() const {
  if (!impl_) throw Error("map store: used after it was moved from");
  return *impl_;
}

int Store::schema_version() const { return impl().schema_version(); }
const std::string& Store::path() const { return impl().path(); }

// The arguments of the writing calls are checked here, once, in front of both engines.

MapInfo Store::create_map(const std::string& name, const GeoPoint& origin, double tile_size, double voxel_size) {
  if (!api::valid_map_name(name))
    throw Error(path() + ": invalid map name \"" + name + "\": use 1 to 64 of A-Z a-z 0-9 _ . -");
  if (!(origin.lat_deg >= -90 && origin.lat_deg <= 90) || !(origin.lon_deg >= -180 && origin.lon_deg <= 180) ||
      !std::isfinite(origin.alt_m))
    throw Error(path() + ": map " + name +
                ": the origin must be a latitude in [-90, 90], a longitude in [-180, 180] "
                "and a finite altitude (degrees, metres)");
  if (!(tile_size > 0) || !std::isfinite(tile_size) || !(voxel_size > 0) || !std::isfinite(voxel_size))
    throw Error(path() + ": map " + name + ": tile and voxel sizes must be positive numbers of metres");
  return impl().create_map(name, origin, tile_size, voxel_size);
}
std::optional<MapInfo> Store::find_map(const std::string& name) const { return impl().find_map(name); }
std::vector<MapInfo> Store::list_maps() const { return impl().list_maps(); }

VersionInfo Store::create_version(const std::string& map, std::optional<std::int64_t> parent, const std::string& note) {
  return impl().create_version(map, parent, note);
}
std::optional<VersionInfo> Store::find_version(const std::string& map, std::int64_t number) const {
  return impl().find_version(map, number);
}
std::vector<VersionInfo> Store::list_versions(const std::string& map) const { return impl().list_versions(map); }
void Store::publish(const std::string& map, std::int64_t number) { impl().publish(map, number, std::nullopt, std::nullopt); }
bool Store::publish_if_current(const std::string& map, std::int64_t number, std::optional<std::int64_t> expected_current) {
  return impl().publish(map, number, std::optional<std::optional<std::int64_t>>(expected_current), std::nullopt);
}

std::int64_t Store::rollback_target(const std::string& map) const { return impl().rollback_target(map); }

std::int64_t Store::rollback(const std::string& map, const std::function<void(std::int64_t)>& before_publish) {
  Transaction tx(*this);
  const auto current = find_map(map);
  const std::int64_t target = rollback_target(map);  // throws for an unknown map, or nothing to roll back to
  const std::int64_t from = current->current.value();
  const VersionInfo v = create_version(
      map, target, "rollback of v" + std::to_string(from) + ": the tiles and places of v" + std::to_string(target));
  if (before_publish) before_publish(v.number);
  if (!impl().publish(map, v.number, std::optional<std::optional<std::int64_t>>(from), target))
    throw Error(path() + ": map " + map + ": another version was published while version " + std::to_string(from) +
                " was being rolled back: nothing rolled back; look at pl-map list, then roll back again if still wanted");
  tx.commit();
  return v.number;
}

TileRecord Store::put_tile(const std::string& map, std::int64_t version, const TileKey& key, std::string_view draco_bytes,
                           std::int64_t points, double min_x, double min_y, double min_z, double max_x, double max_y,
                           double max_z) {
  const std::string where = path() + ": map " + map + " version " + std::to_string(version) + " tile (" +
                            std::to_string(key.tx) + ", " + std::to_string(key.ty) + ")";
  if (draco_bytes.empty()) throw Error(where + ": empty tile data");
  if (draco_bytes.size() > detail::kMaxTileBytes)
    throw Error(where + ": " + std::to_string(draco_bytes.size()) + " bytes of tile data, more than the store's limit of " +
                std::to_string(detail::kMaxTileBytes >> 20) + " MiB");
  if (points < 0) throw Error(where + ": negative point count");
  for (double v : {min_x, min_y, min_z, max_x, max_y, max_z})
    if (!std::isfinite(v)) throw Error(where + ": bounds must be finite numbers");
  if (!(min_x <= max_x && min_y <= max_y && min_z <= max_z)) throw Error(where + ": bounds have min > max");
  return impl().put_tile(map, version, key, draco_bytes, points, min_x, min_y, min_z, max_x, max_y, max_z);
}
bool Store::delete_tile(const std::string& map, std::int64_t version, const TileKey& key) {
  return impl().delete_tile(map, version, key);
}
std::optional<TileRecord> Store::find_tile(const std::string& map, std::int64_t version, const TileKey& key) const {
  return impl().find_tile(map, version, key);
}
std::vector<TileRecord> Store::list_tiles(const std::string& map, std::int64_t version) const {
  return impl().list_tiles(map, version);
}
std::vector<TileRecord> Store::tiles_in_box(const std::string& map, std::int64_t version, double min_x, double min_y,
                                            double max_x, double max_y) const {
  return impl().tiles_in_box(map, version, min_x, min_y, max_x, max_y);
}
std::optional<std::string> Store::blob(const std::string& hash) const { return impl().blob(hash); }
bool Store::has_blob(const std::string& hash) const { return impl().has_blob(hash); }

void Store::put_places(const std::string& map, std::int64_t version, std::string_view bytes) {
  impl().put_places(map, version, bytes);
}
bool Store::delete_places(const std::string& map, std::int64_t version) { return impl().delete_places(map, version); }
std::optional<std::string> Store::places(const std::string& map, std::int64_t version) const {
  return impl().places(map, version);
}
std::optional<std::string> Store::places_hash(const std::string& map, std::int64_t version) const {
  return impl().places_hash(map, version);
}

void Store::put_signature(const std::string& map, std::int64_t version, std::string_view public_key, std::string_view signature) {
  if (public_key.size() != 32 || signature.size() != 64)
    throw Error(path() + ": map " + map + " version " + std::to_string(version) +
                ": an Ed25519 signature is a 32-byte public key and a 64-byte signature, got " + std::to_string(public_key.size()) +
                " and " + std::to_string(signature.size()) + " bytes");
  impl().put_signature(map, version, public_key, signature);
}
std::optional<Store::Signature> Store::signature(const std::string& map, std::int64_t version) const {
  return impl().signature(map, version);
}

std::int64_t Store::add_token(const std::string& token, Role role, const std::string& note) {
  if (token.empty()) throw Error(path() + ": empty token");
  if (!parse_role(role_name(role))) throw Error(path() + ": invalid role " + std::to_string(static_cast<int>(role)));
  return impl().add_token(token, role, note);
}

std::optional<Store::TokenInfo> Store::find_token(const std::string& token) const {
  if (token.empty()) return std::nullopt;
  const std::string hash = content_hash(token);
  auto found = impl().token_by_hash(hash);
  // The engine found the row by the hash; the equality that decides is made here, in constant time.
  if (!found || found->second.size() != hash.size() || CRYPTO_memcmp(found->second.data(), hash.data(), hash.size()) != 0 ||
      found->first.revoked)
    return std::nullopt;
  return found->first;
}

std::optional<Role> Store::check_token(const std::string& token) const {
  auto t = find_token(token);
  return t ? std::optional<Role>(t->role) : std::nullopt;
}

bool Store::revoke_token(std::int64_t id) { return impl().revoke_token(id); }
std::vector<Store::TokenInfo> Store::list_tokens() const { return impl().list_tokens(); }

void Store::log_upload(const std::string& map, std::optional<std::int64_t> version, const std::string& action,
                       const std::string& detail, const std::string& who) {
  if (action.empty()) throw Error(path() + ": upload log entry without an action");
  impl().log_upload(map, version, action, detail, who);
}
std::vector<Store::LogEntry> Store::upload_log(const std::string& map) const { return impl().upload_log(map); }

Store::ReportPut Store::put_report(const std::string& map, std::int64_t version, const std::string& vehicle,
                                   const std::string& drive, double start, double end, std::string_view body,
                                   const std::string& who) {
  if (!api::valid_map_name(map))
    throw Error(path() + ": invalid map name \"" + printable(map, 80) + "\": use 1 to 64 of A-Z a-z 0-9 _ . -");
  const std::string where = path() + ": map " + map + " version " + std::to_string(version) + ": change report";
  if (!detail::valid_report_id(vehicle)) throw Error(where + ": the vehicle id must be 1 to 128 of A-Z a-z 0-9 _ . : -");
  if (!detail::valid_report_id(drive)) throw Error(where + ": the drive id must be 1 to 128 of A-Z a-z 0-9 _ . : -");
  const std::string of = where + " of vehicle " + vehicle + " drive " + drive;
  if (!std::isfinite(start) || !std::isfinite(end) || !(start <= end))
    throw Error(of + ": the drive's span must be finite times with start <= end (seconds since 1970)");
  if (body.empty()) throw Error(of + ": empty report (a report is the JSON the vehicle sent)");
  if (body.size() > detail::kMaxReportBytes)
    throw Error(of + ": " + std::to_string(body.size()) + " bytes, more than the store's limit of " +
                std::to_string(detail::kMaxReportBytes >> 20) + " MiB (send the drive's evidence in several reports)");
  if (who.empty()) throw Error(of + ": empty sender (who: \"token 7\", as the upload log names them)");
  return impl().put_report(map, version, vehicle, drive, start, end, body, content_hash(body), who);
}
std::vector<Store::ReportInfo> Store::list_reports(const std::string& map, std::optional<std::int64_t> version) const {
  return impl().list_reports(map, version);
}
std::optional<std::string> Store::report_body(const std::string& map, std::int64_t id) const {
  return impl().report_body(map, id);
}
std::int64_t Store::delete_reports(const std::string& map, const std::string& received_before) {
  if (!valid_timestamp(received_before))
    throw Error(path() + ": map " + map + ": delete_reports takes a UTC time as the store writes them, "
                "YYYY-MM-DDTHH:MM:SS.sssZ (2024-05-01T10:11:12.345Z), got \"" + printable(received_before, 80) + "\"");
  return impl().delete_reports(map, received_before);
}

Store::Transaction::Transaction(Store& store) : store_(store) { nested_ = store_.impl().begin_transaction(); }

void Store::Transaction::commit() {
  if (done_) throw Error(store_.path() + ": transaction committed twice");
  store_.impl().commit_transaction(nested_);
  done_ = true;
}

Store::Transaction::~Transaction() {
  if (!done_ && store_.impl_) store_.impl_->rollback_transaction_quietly(nested_);
}

std::int64_t Store::database_bytes() const { return impl().database_bytes(); }
bool Store::usable() const { return impl_ && impl_->usable(); }
bool Store::integrity_ok() const { return impl().integrity_ok(true); }

}  // namespace pl::store

// The exact copy of a whole store between engines (pl/schema/store_copy.hpp): the source's rows
// exported (StoreBackend::export_rows) straight into the destination's importer in one transaction,
// digested on the way, read back and digested again before the commit. The engines' halves are
// store_copy_sqlite.cpp and store_pg_copy.cpp.
#include "pl/schema/store_copy.hpp"

#include <openssl/evp.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <memory>
#include <sys/stat.h>

#include "pl/common/error.hpp"
#include "pl/schema/store.hpp"
#include "store_backend.hpp"

namespace pl::store {

namespace {

using detail::RowSink;
using Table = RowSink::Table;

const char* table_name(Table t) {
  switch (t) {
    case Table::Maps:
      return "maps";
    case Table::Versions:
      return "versions";
    case Table::Blobs:
      return "blobs";
    case Table::Tiles:
      return "tiles";
    case Table::Places:
      return "places";
    case Table::Signatures:
      return "signatures";
    case Table::Tokens:
      return "tokens";
    case Table::UploadLog:
      return "upload log";
    case Table::ChangeReports:
      return "change reports";
  }
  return "rows";
}

// The canonical digest: SHA-256 over every row in export order (each table in key order), each
// row a tag byte and its fields — integers as 8 bytes little-endian, doubles as their IEEE bits
// (-0 as +0: SQLite keeps no sign on a zero), text and bytes with their length first, and a
// presence byte before an optional value. Blobs, places and change reports enter by hash and size:
// their reader has checked that the bytes hash to it. The change reports' table (schema 5) enters
// only when it holds a report: a store without any has the digest it had before, so digests taken
// before the upgrade still compare.
class DigestSink final : public RowSink {
 public:
  DigestSink() : ctx_(EVP_MD_CTX_new()) {
    if (!ctx_ || EVP_DigestInit_ex(ctx_, EVP_sha256(), nullptr) != 1) throw Error("SHA-256 failed (OpenSSL EVP_DigestInit_ex)");
  }
  ~DigestSink() override { EVP_MD_CTX_free(ctx_); }
  DigestSink(const DigestSink&) = delete;
  DigestSink& operator=(const DigestSink&) = delete;

  void begin_table(Table t, std::int64_t rows) override {
    if (t == Table::ChangeReports && rows == 0) return;
    tag(static_cast<unsigned char>(0x80 + static_cast<int>(t)));
  }
  void map(const detail::MapRow& m) override {
    tag('M');
    put(m.id), put(m.name), put(m.origin_lat), put(m.origin_lon), put(m.origin_alt), put(m.tile_size);
    put(m.voxel_size), put(m.current_version), put(m.created);
  }
  void version(const detail::VersionRow& v) override {
    tag('V');
    put(v.id), put(v.map_id), put(v.number), put(v.parent), put(std::string(state_name(v.state)));
    put(v.created), put(v.note), put(v.published), put(v.replaces);
  }
  void blob(const detail::BlobRow& b) override {
    tag('B');
    put(b.hash), put(static_cast<std::int64_t>(b.bytes.size()));
  }
  void tile(const detail::TileRow& t) override {
    tag('T');
    put(t.id), put(t.map_id), put(t.version), put(t.tx), put(t.ty), put(t.hash), put(t.points), put(t.bytes);
    put(t.min_x), put(t.min_y), put(t.min_z), put(t.max_x), put(t.max_y), put(t.max_z);
  }
  void places(const detail::PlacesRow& p) override {
    tag('P');
    put(p.id), put(p.map_id), put(p.version), put(p.hash), put(static_cast<std::int64_t>(p.bytes.size()));
  }
  void signature(const detail::SignatureRow& s) override {
    tag('S');
    put(s.id), put(s.map_id), put(s.version), put(s.public_key), put(s.signature), put(s.signed_at);
  }
  void token(const detail::TokenRow& t) override {
    tag('K');
    put(t.id), put(t.hash), put(std::string(role_name(t.role))), put(t.note), put(t.created), put(t.revoked);
  }
  void log(const detail::LogRow& e) override {
    tag('L');
    put(e.id), put(e.at), put(e.map), put(e.version), put(e.action), put(e.detail), put(e.who);
  }
  void report(const detail::ReportRow& r) override {
    tag('R');
    put(r.id), put(r.map_id), put(r.version), put(r.vehicle), put(r.drive), put(r.start), put(r.end), put(r.hash);
    put(static_cast<std::int64_t>(r.body.size())), put(r.received), put(r.who);
  }

  std::string hex() {
    unsigned char md[EVP_MAX_MD_SIZE];
    unsigned int n = 0;
    if (EVP_DigestFinal_ex(ctx_, md, &n) != 1) throw Error("SHA-256 failed (OpenSSL EVP_DigestFinal_ex)");
    static const char digits[] = "0123456789abcdef";
    std::string out;
    for (unsigned int i = 0; i < n; ++i) out += {digits[md[i] >> 4], digits[md[i] & 0xF]};
    return out;
  }

 private:
  void raw(const void* p, std::size_t n) {
    if (EVP_DigestUpdate(ctx_, p, n) != 1) throw Error("SHA-256 failed (OpenSSL EVP_DigestUpdate)");
  }
  void tag(unsigned char c) { raw(&c, 1); }
  void put(std::int64_t v) {
    unsigned char b[8];
    const auto u = static_cast<std::uint64_t>(v);
    for (int i = 0; i < 8; ++i) b[i] = static_cast<unsigned char>(u >> (8 * i));
    raw(b, 8);
  }
  void put(double v) {
    const double canonical = v == 0 ? 0.0 : v;
    std::uint64_t bits = 0;
    std::memcpy(&bits, &canonical, sizeof(bits));
    put(static_cast<std::int64_t>(bits));
  }
  void put(const std::string& s) {
    put(static_cast<std::int64_t>(s.size()));
    raw(s.data(), s.size());
  }
  void put(const std::optional<std::int64_t>& v) {
    tag(v ? 1 : 0);
    if (v) put(*v);
  }
  void put(const std::optional<std::string>& v) {
    tag(v ? 1 : 0);
    if (v) put(*v);
  }

  EVP_MD_CTX* ctx_;
};

// The copy's path for each row: digested, counted, written to the destination, reported.
class CopySink final : public RowSink {
 public:
  CopySink(RowSink& dest, const CopyProgress& progress, CopyReport& report)
      : dest_(dest), progress_(progress), report_(report) {}

  void begin_table(Table t, std::int64_t rows) override {
    digest_.begin_table(t, rows);
    dest_.begin_table(t, rows);
    stage_ = table_name(t);
    total_ = rows > 0 ? static_cast<std::size_t>(rows) : 0;
    done_ = 0;
    if (progress_) progress_(stage_, 0, total_);
  }
  void map(const detail::MapRow& m) override {
    digest_.map(m), dest_.map(m), ++report_.maps, step();
  }
  void version(const detail::VersionRow& v) override {
    digest_.version(v), dest_.version(v), ++report_.versions, step();
  }
  void blob(const detail::BlobRow& b) override {
    digest_.blob(b), dest_.blob(b), ++report_.blobs, step();
    report_.blob_bytes += static_cast<std::int64_t>(b.bytes.size());
  }
  void tile(const detail::TileRow& t) override {
    digest_.tile(t), dest_.tile(t), ++report_.tiles, step();
  }
  void places(const detail::PlacesRow& p) override {
    digest_.places(p), dest_.places(p), ++report_.places, step();
  }
  void signature(const detail::SignatureRow& s) override {
    digest_.signature(s), dest_.signature(s), ++report_.signatures, step();
  }
  void token(const detail::TokenRow& t) override {
    digest_.token(t), dest_.token(t), ++report_.tokens, step();
  }
  void log(const detail::LogRow& e) override {
    digest_.log(e), dest_.log(e), ++report_.log_entries, step();
  }
  void report(const detail::ReportRow& r) override {
    digest_.report(r), dest_.report(r), ++report_.reports, step();
  }
  void finish() override { dest_.finish(); }

  std::string digest() { return digest_.hex(); }

 private:
  void step() {
    ++done_;
    if (progress_) progress_(stage_, done_, total_);
  }

  RowSink& dest_;
  const CopyProgress& progress_;
  CopyReport& report_;
  DigestSink digest_;
  std::string stage_;
  std::size_t done_ = 0, total_ = 0;
};

// The read-back before the commit: the digest, and the verifying stage's progress (tables done).
class VerifySink final : public RowSink {
 public:
  explicit VerifySink(const CopyProgress& progress) : progress_(progress) {}
  void begin_table(Table t, std::int64_t rows) override {
    if (progress_) progress_("verifying", static_cast<std::size_t>(t), kTables);
    digest_.begin_table(t, rows);
  }
  void map(const detail::MapRow& m) override { digest_.map(m); }
  void version(const detail::VersionRow& v) override { digest_.version(v); }
  void blob(const detail::BlobRow& b) override { digest_.blob(b); }
  void tile(const detail::TileRow& t) override { digest_.tile(t); }
  void places(const detail::PlacesRow& p) override { digest_.places(p); }
  void signature(const detail::SignatureRow& s) override { digest_.signature(s); }
  void token(const detail::TokenRow& t) override { digest_.token(t); }
  void log(const detail::LogRow& e) override { digest_.log(e); }
  void report(const detail::ReportRow& r) override { digest_.report(r); }
  std::string digest() {
    if (progress_) progress_("verifying", kTables, kTables);
    return digest_.hex();
  }

 private:
  static constexpr std::size_t kTables = static_cast<std::size_t>(Table::ChangeReports) + 1;
  const CopyProgress& progress_;
  DigestSink digest_;
};

std::unique_ptr<detail::StoreBackend> open_backend(const std::string& db, bool create) {
  if (db.empty()) throw Error("map store: empty database path");
  return is_postgres_url(db) ? detail::open_postgres(db, create) : detail::open_sqlite(db, create);
}

std::string plural(std::int64_t n, const char* one, const char* many) {
  return std::to_string(n) + " " + (n == 1 ? one : many);
}

// The copy into an open destination, in one transaction on it: committed only once the rows read
// back to the source's digest and the store's integrity check passes.
void copy_into(const detail::StoreBackend& src, detail::StoreBackend& dst, const CopyProgress& progress,
               CopyReport& report) {
  if (dst.begin_transaction()) {
    dst.rollback_transaction_quietly(true);
    throw Error(dst.path() + ": internal error: the copy's transaction is nested in another one");
  }
  try {
    // The importer first: on PostgreSQL it locks the tables, so nothing is written between the
    // check below and the copy.
    auto importer = dst.importer();
    const detail::StoreContent held = dst.content();
    if (!held.empty())
      throw Error(dst.path() + ": the map store is not empty (it holds " + plural(held.maps, "map", "maps") + ", " +
                  plural(held.blobs, "tile blob", "tile blobs") + ", " + plural(held.tokens, "token", "tokens") + ", " +
                  plural(held.log_entries, "upload log entry", "upload log entries") +
                  "): migrate into a new SQLite file or an empty PostgreSQL database (createdb NAME)");
    CopySink sink(*importer, progress, report);
    src.export_rows(sink);
    sink.finish();
    report.digest = sink.digest();
    VerifySink check(progress);
    dst.export_rows(check);
    const std::string copied = check.digest();
    if (copied != report.digest)
      throw Error(dst.path() + ": the copy does not read back as the original (content digest " + copied +
                  ", the original's " + report.digest + "): nothing was written; report this as a bug");
    // The hashes of the blobs, places and reports were checked by the read-back (export_rows): not read again.
    if (!dst.integrity_ok(false))
      throw Error(dst.path() + ": the copy fails the store's integrity check: nothing was written; report this as a bug");
    dst.commit_transaction(false);
  } catch (...) {
    dst.rollback_transaction_quietly(false);
    throw;
  }
}

bool file_exists(const std::string& path) {
  struct stat st {};
  return ::stat(path.c_str(), &st) == 0;
}

}  // namespace

CopyReport copy_store(const std::string& from, const std::string& to, const CopyProgress& progress) {
  if (from.empty() || to.empty()) throw Error("map store copy: empty source or destination");
  if (from == to)
    throw Error(display_name(to) + ": the source and the destination are the same store: copy into a new SQLite file "
                                   "or an empty PostgreSQL database");
  auto src = open_backend(from, false);
  // A SQLite file the copy creates is removed again when the copy fails: "left as it was".
  const bool creates_file = !is_postgres_url(to) && !file_exists(to);
  CopyReport report;
  try {
    auto dst = open_backend(to, true);
    copy_into(*src, *dst, progress, report);
  } catch (...) {
    // dst is closed by now (it was the try block's).
    if (creates_file)
      for (const char* suffix : {"", "-wal", "-shm", "-journal"}) std::remove((to + suffix).c_str());
    throw;
  }
  return report;
}

std::string store_digest(const std::string& db) {
  auto store = open_backend(db, false);
  DigestSink digest;
  store->export_rows(digest);
  return digest.hex();
}

std::optional<std::string> checked_digest(const std::string& db) {
  auto store = open_backend(db, false);
  // Every check but the bytes' hashes, which the digest's read makes (DamagedBytes).
  if (!store->integrity_ok(false)) return std::nullopt;
  DigestSink digest;
  try {
    store->export_rows(digest);
  } catch (const detail::DamagedBytes&) {
    return std::nullopt;
  }
  return digest.hex();
}

}  // namespace pl::store

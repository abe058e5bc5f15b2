// The checks the map store and the tile cache make on a file before they write anything to it
// (pl/schema/detail/sqlite.hpp): its header, what kind of file it is, its schema, its pages.

#include "pl/common/error.hpp"
#include "pl/schema/detail/sqlite.hpp"

namespace pl::sqlite {

namespace {

// Errors on the first read that mean SQLite cannot use the file's header or schema: "unsupported
// file format" (a format number no SQLite writes) and a schema that does not parse are plain
// SQLITE_ERRORs, and SQLite answers some damaged schemas with SQLITE_NOMEM. (Not: BUSY and LOCKED,
// another connection at work; IOERR and CANTOPEN, the disk.)
bool unusable_file(int rc) {
  int primary = rc & 0xFF;
  return primary == SQLITE_ERROR || primary == SQLITE_NOMEM || primary == SQLITE_CORRUPT || primary == SQLITE_TOOBIG ||
         primary == SQLITE_FORMAT || primary == SQLITE_RANGE || primary == SQLITE_MISMATCH;
}

[[noreturn]] void not_this_kind(const Db& db, const std::string& why) {
  throw Error(db.path() + ": not a " + db.kind().name + " (" + why + "): " + db.kind().if_other);
}

bool made_by_sqlite(const std::string& name, const std::vector<std::string>& shadow_prefixes) {
  if (name.rfind("sqlite_", 0) == 0) return true;
  for (const std::string& prefix : shadow_prefixes)
    if (name.rfind(prefix, 0) == 0) return true;
  return false;
}

}  // namespace

Header read_header(const Db& db) {
  Header h;
  sqlite3_stmt* st = nullptr;
  int rc = sqlite3_prepare_v2(db.get(),
                              "SELECT a.application_id, u.user_version, (SELECT count(*) FROM sqlite_schema) "
                              "FROM pragma_application_id AS a, pragma_user_version AS u",
                              -1, &st, nullptr);
  if (rc == SQLITE_OK) rc = sqlite3_step(st);
  if (rc == SQLITE_ROW) {
    h.application_id = sqlite3_column_int64(st, 0);
    h.user_version = sqlite3_column_int64(st, 1);
    h.objects = sqlite3_column_int64(st, 2);
  }
  sqlite3_finalize(st);
  if ((rc & 0xFF) == SQLITE_NOTADB)
    not_this_kind(db, std::string("not a SQLite database: ") + sqlite3_errmsg(db.get()));
  if (rc != SQLITE_ROW && unusable_file(rc))
    damaged(db, std::string(sqlite3_errmsg(db.get())) +
                    ((rc & 0xFF) == SQLITE_NOMEM ? ", which SQLite also reports for some damaged files" : ""));
  if (rc != SQLITE_ROW) fail(db, "reading the database header");
  // SQLite opens a file whose header has a write version above 2 read-only (the file itself was
  // found writable before this first read: prepare_connection).
  if (sqlite3_db_readonly(db.get(), "main") == 1)
    damaged(db, "its header says SQLite may only read it (a file format write version other than 1 or 2)");
  return h;
}

void check_identity(const Db& db, const Header& h, std::int64_t latest) {
  const std::int64_t own = db.kind().application_id;
  if (h.application_id != 0 && h.application_id != own)
    not_this_kind(db, "a SQLite database of another application, application_id " + std::to_string(h.application_id));
  if (h.user_version > latest) refuse_newer(db, h.user_version, latest);
  if (h.user_version < 0) damaged(db, "negative schema version " + std::to_string(h.user_version));
  if (h.user_version == 0 && h.objects > 0) not_this_kind(db, "a SQLite database with tables but no schema version");
  if (h.user_version > 0 && h.application_id != own)
    not_this_kind(db, "a SQLite database with a schema version but application_id " + std::to_string(h.application_id));
}

void refuse_newer(const Db& db, std::int64_t version, std::int64_t latest) {
  throw Error(db.path() + ": the " + db.kind().name + " has schema version " + std::to_string(version) +
              ", newer than this build knows (" + std::to_string(latest) + "): " + db.kind().if_newer);
}

// ---- schemas -------------------------------------------------------------------------------------

Schema read_schema(const Db& db, const std::vector<std::string>& shadow_prefixes) {
  Schema out;
  Stmt st(db, "SELECT type, name, sql FROM sqlite_schema");
  while (st.step()) {
    std::string name = st.text(1);
    out[{st.text(0), name}] = made_by_sqlite(name, shadow_prefixes) ? "" : st.text(2);
  }
  return out;
}

Schema schema_of(const FileKind& kind, const std::vector<const char*>& scripts,
                 const std::vector<std::string>& shadow_prefixes) {
  const std::string label = std::string("(the ") + kind.name + " schema)";
  sqlite3* handle = nullptr;
  if (sqlite3_open(":memory:", &handle) != SQLITE_OK) {
    sqlite3_close(handle);
    throw Error(std::string(kind.name) + ": cannot open an in-memory SQLite database (out of memory?)");
  }
  const Db db(handle, label, kind);
  Schema out;
  try {
    for (const char* sql : scripts) exec(db, sql);
    out = read_schema(db, shadow_prefixes);
  } catch (...) {
    sqlite3_close(handle);
    throw;
  }
  sqlite3_close(handle);
  return out;
}

void check_schema(const Db& db, const Schema& want, const std::string& head,
                  const std::vector<std::string>& shadow_prefixes) {
  const Schema have = read_schema(db, shadow_prefixes);
  const std::string lead = head + ": ";
  for (const auto& [key, sql] : want) {
    auto it = have.find(key);
    if (it == have.end()) damaged(db, lead + key.first + " " + key.second + " is missing");
    if (it->second != sql) damaged(db, lead + key.first + " " + key.second + " is not defined as this software defines it");
  }
  for (const auto& [key, sql] : have) {
    bool statistics = key.first == "table" && (key.second == "sqlite_stat1" || key.second == "sqlite_stat4");
    if (!want.count(key) && !statistics) damaged(db, lead + "it has an unknown " + plain(key.first) + " " + plain(key.second));
  }
}

// ---- pages and journal ---------------------------------------------------------------------------

void quick_check(const Db& db) {
  Stmt st(db, "PRAGMA quick_check");
  std::string first = st.step() ? st.text(0) : "no answer";
  if (first != "ok") damaged(db, "quick_check: " + plain(first));
}

std::string journal_mode(const Db& db) {
  Stmt st(db, "PRAGMA journal_mode");
  return st.step() ? st.text(0) : "";
}

void use_wal(const Db& db) {
  {
    Stmt st(db, "PRAGMA journal_mode = WAL");
    std::string mode = st.step() ? st.text(0) : "";
    if (mode != "wal" && db.path() != ":memory:")
      throw Error(db.path() + ": cannot switch the " + db.kind().name + " to WAL journal mode (journal_mode is \"" +
                  plain(mode) + "\"; WAL needs a local file system)");
  }
  exec(db, "PRAGMA synchronous = NORMAL");
}

}  // namespace pl::sqlite

// The exact copy of a whole map store into another, between any two engines (SQLite file ->
// PostgreSQL database, and back, or to the same engine): `pl-map migrate`.
//
// Exact: every row of every table, as it is — maps (their ids, origins, sizes, created times,
// current versions), versions (numbers, parents, states, notes, created and published times, and the
// publish history a rollback walks back through: a rollback on the copy returns what it returns on
// the original, again and again), tile records, blobs (once per SHA-256), places, signatures,
// tokens (their stored hashes, roles, notes, created and revoked times: a token that opens the
// original opens the copy, a revoked one stays revoked), the upload log (ids, times, everything)
// and the fleet's change reports (ids, received times, bytes).
// Timestamps are copied to the millisecond, the store's precision (store.hpp); PostgreSQL's
// microseconds beyond it are not.
//
// - The destination is a SQLite file (created when missing) or an existing PostgreSQL database
//   (migrated when it has no store yet). It must be empty: no maps, blobs, tokens or upload log
//   entries, else pl::Error "DEST: the map store is not empty (...)" naming what it holds and
//   the fix, and nothing is written.
// - The whole copy is one transaction on the destination: when anything fails (the source found
//   damaged half-way, a value the destination cannot hold, a lost connection), the destination is
//   left as it was; a SQLite file the copy created is removed again.
// - The source is read from one snapshot (writers on it may go on; the copy is of the moment it
//   started). Blobs, places and change reports pass through a few at a time: a store larger than
//   memory is fine.
// - Before committing, the destination's rows are read back and their digest (store_digest) must
//   be the source's, and integrity_ok() must hold (its hashes of the blobs made by the read-back,
//   which reads each blob once); else pl::Error, and nothing is committed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <optional>
#include <string>

namespace pl::store {

struct CopyReport {
  std::int64_t maps = 0, versions = 0, tiles = 0, blobs = 0;
  std::int64_t blob_bytes = 0;  // the blobs' bytes (each blob once)
  std::int64_t places = 0, signatures = 0, tokens = 0, log_entries = 0, reports = 0;
  std::string digest;  // of both stores' content (store_digest), equal on both
};

// progress(stage, done, total): the stage ("maps", "versions", "blobs", ..., "verifying") and how
// many of its rows are done; may be empty.
using CopyProgress = std::function<void(const std::string& stage, std::size_t done, std::size_t total)>;

// Copies the store `from` (a SQLite file or a postgresql:// URL; it must exist) into `to` (the same
// kinds), exactly (above). Every error is a pl::Error naming the store (a URL without its password).
CopyReport copy_store(const std::string& from, const std::string& to, const CopyProgress& progress = {});

// The canonical digest of a store's content (SHA-256, lowercase hex): every row of every table the
// copy moves, ids and timestamps included, in a fixed order and encoding that do not depend on the
// engine. Two stores with the same digest hold the same maps, versions, history, tiles, blob bytes,
// places, signatures, tokens, log and change reports. A store without change reports has the digest
// it had before schema version 5 (which added them). Reads the store in one snapshot; a damaged store is an error.
std::string store_digest(const std::string& db);

// `pl-map check`: the store checked as Store::integrity_ok() checks it and, when it is sound, its
// store_digest — in one read of every blob (hashed once, for both). An empty optional when the
// store is damaged (integrity_ok() would be false, or a blob, places or change report does not hash
// to its hash); other failures (the store out of reach, a value store_digest refuses) are the pl::Error they are.
std::optional<std::string> checked_digest(const std::string& db);

}  // namespace pl::store

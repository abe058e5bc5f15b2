-- Migration 5: change reports from the fleet, and the report role.
--
-- A vehicle that localized against a map version sends what it saw of the map's age over one drive
-- (pl/schema/change_report.hpp); the store keeps the JSON as it was sent, one row per (map,
-- vehicle, drive): a report sent again is the same report. The store does not parse the body (the
-- server has, before it stores it) but keeps its SHA-256, checked on read like a blob's. Reports
-- never change (a trigger refuses UPDATE); old ones are deleted (retention). They belong to an
-- existing version of the map, whatever its state.
--
-- A token may have the role 'report' (a vehicle's: it reads maps and sends reports), between read
-- and upload. SQLite cannot change a CHECK constraint, so tokens is built again, with every column
-- (revoked: migration 3), id and row. Migrations run with foreign keys off; no table refers to
-- tokens.

ALTER TABLE tokens RENAME TO tokens_v4;

-- API tokens: only the SHA-256 (lowercase hex) of a token is stored, never the token.
CREATE TABLE tokens (
  id INTEGER PRIMARY KEY,
  hash TEXT NOT NULL UNIQUE CHECK (length(hash) = 64 AND hash NOT GLOB '*[^0-9a-f]*'),
  role TEXT NOT NULL CHECK (role IN ('read', 'report', 'upload', 'admin')),
  note TEXT NOT NULL DEFAULT '',
  created TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  -- When the token was revoked (NULL: in force).
  revoked TEXT
);

INSERT INTO tokens (id, hash, role, note, created, revoked)
SELECT id, hash, role, note, created, revoked FROM tokens_v4 ORDER BY id;

DROP TABLE tokens_v4;

CREATE TABLE change_reports (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL,
  version INTEGER NOT NULL,
  -- Who drove and which drive: 1 to 128 of [A-Za-z0-9_.:-], as the report's parser takes them.
  vehicle TEXT NOT NULL CHECK (length(vehicle) BETWEEN 1 AND 128 AND vehicle NOT GLOB '*[^A-Za-z0-9_.:-]*'),
  drive TEXT NOT NULL CHECK (length(drive) BETWEEN 1 AND 128 AND drive NOT GLOB '*[^A-Za-z0-9_.:-]*'),
  -- The drive's span as the report says, seconds since 1970.
  start_s REAL NOT NULL,
  end_s REAL NOT NULL,
  -- SHA-256 of the body, lowercase hex.
  hash TEXT NOT NULL CHECK (length(hash) = 64 AND hash NOT GLOB '*[^0-9a-f]*'),
  body BLOB NOT NULL,
  size INTEGER NOT NULL CHECK (size > 0 AND size = length(body)),
  received TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  -- Who sent it, as the upload log names them ("token 7").
  who TEXT NOT NULL CHECK (length(who) > 0),
  CHECK (start_s <= end_s),
  UNIQUE (map_id, vehicle, drive),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

-- A map's reports by version, in the order received (and the foreign key's lookups).
CREATE INDEX change_reports_version ON change_reports (map_id, version, id);

CREATE TRIGGER change_reports_no_update BEFORE UPDATE ON change_reports
BEGIN
  SELECT RAISE(ABORT, 'change reports never change: rows cannot be updated');
END;

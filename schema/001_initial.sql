-- Migration 1: the initial map store schema.
--
-- Migrations are numbered files NNN_name.sql in this folder, embedded into pl_schema at build time
-- and run by Store::open, each in its own transaction, for every number above PRAGMA user_version.
-- Never edit a released migration: add the next number instead.
--
-- Version numbers (versions.number, tiles.version, maps.current_version, versions.parent,
-- versions.replaces) are per-map numbers 1, 2, ..., not row ids, so every reference to a version
-- is the pair (map_id, number). Timestamps are UTC ISO 8601 with milliseconds and 'Z'.

-- 'PLMS': marks the file as a PointLocalization map store (checked by Store::open).
PRAGMA application_id = 1347177811;

CREATE TABLE maps (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE
    CHECK (length(name) BETWEEN 1 AND 64 AND name NOT GLOB '*[^A-Za-z0-9_.-]*'),
  origin_lat REAL NOT NULL CHECK (origin_lat BETWEEN -90 AND 90),
  origin_lon REAL NOT NULL CHECK (origin_lon BETWEEN -180 AND 180),
  origin_alt REAL NOT NULL,
  tile_size REAL NOT NULL CHECK (tile_size > 0),
  voxel_size REAL NOT NULL CHECK (voxel_size > 0),
  -- The published version readers see; NULL until the first publish.
  current_version INTEGER,
  created TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  FOREIGN KEY (id, current_version) REFERENCES versions (map_id, number)
);

CREATE TABLE versions (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL REFERENCES maps (id),
  number INTEGER NOT NULL CHECK (number >= 1),
  -- The version whose tiles this one started from (NULL: started empty).
  parent INTEGER,
  state TEXT NOT NULL DEFAULT 'staged' CHECK (state IN ('staged', 'published', 'retired')),
  created TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  note TEXT NOT NULL DEFAULT '',
  -- When this version was first published (NULL while staged).
  published TEXT,
  -- The version that was current when this one was published: where a rollback returns to.
  replaces INTEGER,
  UNIQUE (map_id, number),
  FOREIGN KEY (map_id, parent) REFERENCES versions (map_id, number),
  FOREIGN KEY (map_id, replaces) REFERENCES versions (map_id, number)
);

-- At most one published version per map (the current one).
CREATE UNIQUE INDEX versions_one_published ON versions (map_id) WHERE state = 'published';

-- staged -> published (publish), published -> retired (publish of a newer one, rollback),
-- retired -> published (rollback). Nothing ever goes back to staged.
CREATE TRIGGER versions_state_transition BEFORE UPDATE OF state ON versions
WHEN NOT (old.state = new.state
          OR (old.state = 'staged' AND new.state = 'published')
          OR (old.state = 'published' AND new.state = 'retired')
          OR (old.state = 'retired' AND new.state = 'published'))
BEGIN
  SELECT RAISE(ABORT, 'invalid version state change');
END;

-- maps.current_version always names a published version of the map.
CREATE TRIGGER maps_current_is_published BEFORE UPDATE OF current_version ON maps
WHEN new.current_version IS NOT NULL
     AND (SELECT state FROM versions WHERE map_id = new.id AND number = new.current_version) IS NOT 'published'
BEGIN
  SELECT RAISE(ABORT, 'the current version of a map must be published');
END;

-- Draco tile data, stored once per content hash (SHA-256, lowercase hex) and shared by every tile
-- row (of any version or map) with the same bytes.
CREATE TABLE blobs (
  hash TEXT PRIMARY KEY CHECK (length(hash) = 64 AND hash NOT GLOB '*[^0-9a-f]*'),
  bytes BLOB NOT NULL,
  size INTEGER NOT NULL CHECK (size = length(bytes))
);

-- One row per (map, version, tile key). A new version copies its parent's rows (not the blobs).
CREATE TABLE tiles (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL,
  version INTEGER NOT NULL,
  tx INTEGER NOT NULL,
  ty INTEGER NOT NULL,
  hash TEXT NOT NULL REFERENCES blobs (hash),
  points INTEGER NOT NULL CHECK (points >= 0),
  bytes INTEGER NOT NULL CHECK (bytes >= 0),
  -- The box of the tile's points, ENU metres.
  min_x REAL NOT NULL,
  min_y REAL NOT NULL,
  min_z REAL NOT NULL,
  max_x REAL NOT NULL,
  max_y REAL NOT NULL,
  max_z REAL NOT NULL,
  CHECK (min_x <= max_x AND min_y <= max_y AND min_z <= max_z),
  UNIQUE (map_id, version, tx, ty),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

-- Finds the rows that still use a blob (garbage collection of replaced data, foreign key checks).
CREATE INDEX tiles_hash ON tiles (hash);

-- Tiles of published and retired versions are read-only (the store checks first and gives a
-- better message; these are the backstop for any other writer).
CREATE TRIGGER tiles_insert_staged_only BEFORE INSERT ON tiles
WHEN (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'tiles can only be added to a staged version');
END;

CREATE TRIGGER tiles_update_staged_only BEFORE UPDATE ON tiles
WHEN (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS NOT 'staged'
  OR (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'tiles can only be changed in a staged version');
END;

CREATE TRIGGER tiles_delete_staged_only BEFORE DELETE ON tiles
WHEN (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'tiles can only be removed from a staged version');
END;

-- Spatial index over the tiles' xy boxes, one entry per tiles row (same id), kept in step by the
-- triggers below. The R*Tree stores 32-bit floats rounded outwards, so a search returns a superset
-- that the store then filters with the exact bounds in tiles.
CREATE VIRTUAL TABLE tile_rtree USING rtree (id, min_x, max_x, min_y, max_y);

CREATE TRIGGER tiles_rtree_insert AFTER INSERT ON tiles
BEGIN
  INSERT INTO tile_rtree (id, min_x, max_x, min_y, max_y)
  VALUES (new.id, new.min_x, new.max_x, new.min_y, new.max_y);
END;

CREATE TRIGGER tiles_rtree_update AFTER UPDATE OF id, min_x, max_x, min_y, max_y ON tiles
BEGIN
  DELETE FROM tile_rtree WHERE id = old.id;
  INSERT INTO tile_rtree (id, min_x, max_x, min_y, max_y)
  VALUES (new.id, new.min_x, new.max_x, new.min_y, new.max_y);
END;

CREATE TRIGGER tiles_rtree_delete AFTER DELETE ON tiles
BEGIN
  DELETE FROM tile_rtree WHERE id = old.id;
END;

-- API tokens: only the SHA-256 (lowercase hex) of a token is stored, never the token.
CREATE TABLE tokens (
  id INTEGER PRIMARY KEY,
  hash TEXT NOT NULL UNIQUE CHECK (length(hash) = 64 AND hash NOT GLOB '*[^0-9a-f]*'),
  role TEXT NOT NULL CHECK (role IN ('read', 'upload', 'admin')),
  note TEXT NOT NULL DEFAULT '',
  created TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now'))
);

-- Append-only audit log of uploads and version changes. `map` is the name as given (not a foreign
-- key), so attempts on unknown maps can be logged too.
CREATE TABLE upload_log (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  at TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  map TEXT NOT NULL,
  version INTEGER,
  action TEXT NOT NULL CHECK (length(action) > 0),
  detail TEXT NOT NULL DEFAULT '',
  who TEXT NOT NULL DEFAULT ''
);

CREATE INDEX upload_log_map ON upload_log (map, id);

CREATE TRIGGER upload_log_no_update BEFORE UPDATE ON upload_log
BEGIN
  SELECT RAISE(ABORT, 'upload_log is append-only: rows cannot be updated');
END;

CREATE TRIGGER upload_log_no_delete BEFORE DELETE ON upload_log
BEGIN
  SELECT RAISE(ABORT, 'upload_log is append-only: rows cannot be deleted');
END;

-- PostgreSQL migration 1: the initial map store schema, concept for concept the SQLite one
-- (schema/001_initial.sql): the same tables, keys, constraints and triggers in PostgreSQL's dialect.
--
-- Migrations are numbered files NNN_name.sql in this folder, embedded into pl_schema at build time
-- and run by Store::open (store_pg.cpp), each in its own transaction under an advisory lock, for
-- every number above the highest one in schema_migrations. There are exactly as many as there are
-- SQLite migrations (schema/CMakeLists.txt checks it): number N means the same schema on both.
-- Never edit a released migration: add the next number instead.
--
-- Version numbers (versions.number, tiles.version, maps.current_version, versions.parent,
-- versions.replaces) are per-map numbers 1, 2, ..., not row ids, so every reference to a version
-- is the pair (map_id, number). Timestamps are timestamptz; the store reads them as UTC ISO 8601
-- with milliseconds and 'Z'.

-- The migrations applied (SQLite keeps this in PRAGMA user_version). Its comment marks the
-- database as a PointLocalization map store (SQLite: PRAGMA application_id), checked by Store::open.
CREATE TABLE schema_migrations (
  number integer PRIMARY KEY CHECK (number >= 1),
  name text NOT NULL,
  applied timestamptz NOT NULL DEFAULT statement_timestamp()
);
COMMENT ON TABLE schema_migrations IS 'PointLocalization map store (PLMS)';

-- Raises the trigger's first argument as an error: the triggers whose condition fits in WHEN.
CREATE FUNCTION pl_refuse() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
  RAISE EXCEPTION '%', TG_ARGV[0] USING ERRCODE = 'integrity_constraint_violation';
END;
$$;

CREATE TABLE maps (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  name text NOT NULL UNIQUE
    CHECK (length(name) BETWEEN 1 AND 64 AND name ~ '^[A-Za-z0-9_.-]+$'),
  -- BETWEEN refuses NaN (it sorts above every number in PostgreSQL); the other numbers are checked
  -- against infinity for the same reason.
  origin_lat double precision NOT NULL CHECK (origin_lat BETWEEN -90 AND 90),
  origin_lon double precision NOT NULL CHECK (origin_lon BETWEEN -180 AND 180),
  origin_alt double precision NOT NULL CHECK (origin_alt > '-Infinity' AND origin_alt < 'Infinity'),
  tile_size double precision NOT NULL CHECK (tile_size > 0 AND tile_size < 'Infinity'),
  voxel_size double precision NOT NULL CHECK (voxel_size > 0 AND voxel_size < 'Infinity'),
  -- The published version readers see; NULL until the first publish.
  current_version bigint,
  created timestamptz NOT NULL DEFAULT statement_timestamp()
);

CREATE TABLE versions (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  map_id bigint NOT NULL REFERENCES maps (id),
  number bigint NOT NULL CHECK (number >= 1),
  -- The version whose tiles this one started from (NULL: started empty).
  parent bigint,
  state text NOT NULL DEFAULT 'staged' CHECK (state IN ('staged', 'published', 'retired')),
  created timestamptz NOT NULL DEFAULT statement_timestamp(),
  note text NOT NULL DEFAULT '',
  -- When this version was first published (NULL while staged).
  published timestamptz,
  -- The version that was current when this one was published: where a rollback returns to.
  replaces bigint,
  UNIQUE (map_id, number),
  FOREIGN KEY (map_id, parent) REFERENCES versions (map_id, number),
  FOREIGN KEY (map_id, replaces) REFERENCES versions (map_id, number)
);

-- maps and versions reference each other: this key is added once both exist.
ALTER TABLE maps ADD FOREIGN KEY (id, current_version) REFERENCES versions (map_id, number);

-- At most one published version per map (the current one).
CREATE UNIQUE INDEX versions_one_published ON versions (map_id) WHERE state = 'published';

-- staged -> published (publish), published -> retired (publish of a newer one, rollback),
-- retired -> published (rollback). Nothing ever goes back to staged.
CREATE TRIGGER versions_state_transition BEFORE UPDATE OF state ON versions
FOR EACH ROW
WHEN (NOT (old.state = new.state
           OR (old.state = 'staged' AND new.state = 'published')
           OR (old.state = 'published' AND new.state = 'retired')
           OR (old.state = 'retired' AND new.state = 'published')))
EXECUTE FUNCTION pl_refuse('invalid version state change');

-- maps.current_version always names a published version of the map.
CREATE FUNCTION maps_current_is_published() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
  IF (SELECT state FROM versions WHERE map_id = new.id AND number = new.current_version)
     IS DISTINCT FROM 'published' THEN
    RAISE EXCEPTION 'the current version of a map must be published' USING ERRCODE = 'integrity_constraint_violation';
  END IF;
  RETURN new;
END;
$$;

CREATE TRIGGER maps_current_is_published BEFORE UPDATE OF current_version ON maps
FOR EACH ROW WHEN (new.current_version IS NOT NULL)
EXECUTE FUNCTION maps_current_is_published();

-- Draco tile data, stored once per content hash (SHA-256, lowercase hex) and shared by every tile
-- row (of any version or map) with the same bytes.
CREATE TABLE blobs (
  hash text PRIMARY KEY CHECK (hash ~ '^[0-9a-f]{64}$'),
  bytes bytea NOT NULL,
  size bigint NOT NULL CHECK (size = length(bytes))
);

-- One row per (map, version, tile key). A new version copies its parent's rows (not the blobs).
CREATE TABLE tiles (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  map_id bigint NOT NULL,
  version bigint NOT NULL,
  tx integer NOT NULL,
  ty integer NOT NULL,
  hash text NOT NULL REFERENCES blobs (hash),
  points bigint NOT NULL CHECK (points >= 0),
  bytes bigint NOT NULL CHECK (bytes >= 0),
  -- The box of the tile's points, ENU metres.
  min_x double precision NOT NULL,
  min_y double precision NOT NULL,
  min_z double precision NOT NULL,
  max_x double precision NOT NULL,
  max_y double precision NOT NULL,
  max_z double precision NOT NULL,
  -- Finite (NaN sorts above every number, so max < 'Infinity' refuses it too) and min <= max.
  CHECK (min_x > '-Infinity' AND min_y > '-Infinity' AND min_z > '-Infinity'
         AND max_x < 'Infinity' AND max_y < 'Infinity' AND max_z < 'Infinity'
         AND min_x <= max_x AND min_y <= max_y AND min_z <= max_z),
  UNIQUE (map_id, version, tx, ty),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

-- Finds the rows that still use a blob (garbage collection of replaced data, foreign key checks).
CREATE INDEX tiles_hash ON tiles (hash);

-- Tiles of published and retired versions are read-only (the store checks first and gives a
-- better message; these are the backstop for any other writer).
CREATE FUNCTION tiles_staged_only() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
  IF TG_OP = 'INSERT' THEN
    IF (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS DISTINCT FROM 'staged' THEN
      RAISE EXCEPTION 'tiles can only be added to a staged version' USING ERRCODE = 'integrity_constraint_violation';
    END IF;
    RETURN new;
  END IF;
  IF TG_OP = 'UPDATE' THEN
    IF (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS DISTINCT FROM 'staged'
       OR (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS DISTINCT FROM 'staged' THEN
      RAISE EXCEPTION 'tiles can only be changed in a staged version' USING ERRCODE = 'integrity_constraint_violation';
    END IF;
    RETURN new;
  END IF;
  IF (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS DISTINCT FROM 'staged' THEN
    RAISE EXCEPTION 'tiles can only be removed from a staged version' USING ERRCODE = 'integrity_constraint_violation';
  END IF;
  RETURN old;
END;
$$;

CREATE TRIGGER tiles_staged_only BEFORE INSERT OR UPDATE OR DELETE ON tiles
FOR EACH ROW EXECUTE FUNCTION tiles_staged_only();

-- Spatial index over the tiles' xy boxes (SQLite: an R*Tree kept in step by triggers). PostgreSQL's
-- geometric operators compare with a tolerance of 1e-6, so a search through it returns a superset
-- that the store filters with the exact bounds. tiles_in_box uses this expression as it is written
-- here, or the index is not used.
CREATE INDEX tiles_xy ON tiles USING gist (box(point(min_x, min_y), point(max_x, max_y)));

-- API tokens: only the SHA-256 (lowercase hex) of a token is stored, never the token.
CREATE TABLE tokens (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  hash text NOT NULL UNIQUE CHECK (hash ~ '^[0-9a-f]{64}$'),
  role text NOT NULL CHECK (role IN ('read', 'upload', 'admin')),
  note text NOT NULL DEFAULT '',
  created timestamptz NOT NULL DEFAULT statement_timestamp()
);

-- Append-only audit log of uploads and version changes. `map` is the name as given (not a foreign
-- key), so attempts on unknown maps can be logged too. Ids come from a sequence: never reused.
CREATE TABLE upload_log (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  at timestamptz NOT NULL DEFAULT clock_timestamp(),
  map text NOT NULL,
  version bigint,
  action text NOT NULL CHECK (length(action) > 0),
  detail text NOT NULL DEFAULT '',
  who text NOT NULL DEFAULT ''
);

CREATE INDEX upload_log_map ON upload_log (map, id);

CREATE TRIGGER upload_log_no_update BEFORE UPDATE ON upload_log
FOR EACH ROW EXECUTE FUNCTION pl_refuse('upload_log is append-only: rows cannot be updated');

CREATE TRIGGER upload_log_no_delete BEFORE DELETE ON upload_log
FOR EACH ROW EXECUTE FUNCTION pl_refuse('upload_log is append-only: rows cannot be deleted');

-- TRUNCATE runs no row triggers: refused on its own (SQLite has no TRUNCATE).
CREATE TRIGGER upload_log_no_truncate BEFORE TRUNCATE ON upload_log
FOR EACH STATEMENT EXECUTE FUNCTION pl_refuse('upload_log is append-only: it cannot be truncated');

-- Migration 2: the places of a map version.
--
-- A version may carry one blob of places: the place-recognition descriptors built with the map
-- (pl-map build). Their format belongs to the map builder; to the store they are opaque, non-empty
-- bytes. Like tiles, they are written while the version is staged and are read-only once it is
-- published; a new version starts with a copy of its parent's row.

CREATE TABLE places (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL,
  version INTEGER NOT NULL,
  -- SHA-256 of the bytes, lowercase hex (the ETag pl-server sends them with).
  hash TEXT NOT NULL CHECK (length(hash) = 64 AND hash NOT GLOB '*[^0-9a-f]*'),
  bytes BLOB NOT NULL,
  size INTEGER NOT NULL CHECK (size > 0 AND size = length(bytes)),
  UNIQUE (map_id, version),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

-- Places of published and retired versions are read-only (the store checks first and gives a
-- better message; these are the backstop for any other writer).
CREATE TRIGGER places_insert_staged_only BEFORE INSERT ON places
WHEN (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'places can only be added to a staged version');
END;

CREATE TRIGGER places_update_staged_only BEFORE UPDATE ON places
WHEN (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS NOT 'staged'
  OR (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'places can only be changed in a staged version');
END;

CREATE TRIGGER places_delete_staged_only BEFORE DELETE ON places
WHEN (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'places can only be removed from a staged version');
END;

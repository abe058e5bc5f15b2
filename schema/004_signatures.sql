-- Migration 4: signed versions.
--
-- A version may carry one Ed25519 signature of its manifest (pl/schema/signed_manifest.hpp: the
-- map, the version and its parent, origin and grid, places and every tile's key and hash), made
-- by whoever publishes it with the fleet's private key; vehicles holding the public key verify it
-- before they use any tile of the version. The store keeps the public key (32 bytes) and the
-- signature (64 bytes), nothing secret. A signature is written while the version is staged, just
-- before it is published (in the same transaction), and is read-only after; a new version never
-- inherits its parent's.

CREATE TABLE signatures (
  id INTEGER PRIMARY KEY,
  map_id INTEGER NOT NULL,
  version INTEGER NOT NULL,
  public_key BLOB NOT NULL CHECK (typeof(public_key) = 'blob' AND length(public_key) = 32),
  signature BLOB NOT NULL CHECK (typeof(signature) = 'blob' AND length(signature) = 64),
  signed TEXT NOT NULL DEFAULT (strftime('%Y-%m-%dT%H:%M:%fZ', 'now')),
  UNIQUE (map_id, version),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

CREATE TRIGGER signatures_insert_staged_only BEFORE INSERT ON signatures
WHEN (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'a signature can only be added to a staged version');
END;

CREATE TRIGGER signatures_update_staged_only BEFORE UPDATE ON signatures
WHEN (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS NOT 'staged'
  OR (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'a signature can only be changed in a staged version');
END;

CREATE TRIGGER signatures_delete_staged_only BEFORE DELETE ON signatures
WHEN (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS NOT 'staged'
BEGIN
  SELECT RAISE(ABORT, 'a signature can only be removed from a staged version');
END;

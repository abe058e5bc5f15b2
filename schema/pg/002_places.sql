-- PostgreSQL migration 2: the places of a map version (schema/002_places.sql in PostgreSQL's
-- dialect).
--
-- A version may carry one blob of places: the place-recognition descriptors built with the map
-- (pl-map build). Their format belongs to the map builder; to the store they are opaque, non-empty
-- bytes. Like tiles, they are written while the version is staged and are read-only once it is
-- published; a new version starts with a copy of its parent's row.

CREATE TABLE places (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  map_id bigint NOT NULL,
  version bigint NOT NULL,
  -- SHA-256 of the bytes, lowercase hex (the ETag pl-server sends them with).
  hash text NOT NULL CHECK (hash ~ '^[0-9a-f]{64}$'),
  bytes bytea NOT NULL,
  size bigint NOT NULL CHECK (size > 0 AND size = length(bytes)),
  UNIQUE (map_id, version),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

-- Places of published and retired versions are read-only (the store checks first and gives a
-- better message; these are the backstop for any other writer).
CREATE FUNCTION places_staged_only() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
  IF TG_OP = 'INSERT' THEN
    IF (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS DISTINCT FROM 'staged' THEN
      RAISE EXCEPTION 'places can only be added to a staged version' USING ERRCODE = 'integrity_constraint_violation';
    END IF;
    RETURN new;
  END IF;
  IF TG_OP = 'UPDATE' THEN
    IF (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS DISTINCT FROM 'staged'
       OR (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS DISTINCT FROM 'staged' THEN
      RAISE EXCEPTION 'places can only be changed in a staged version' USING ERRCODE = 'integrity_constraint_violation';
    END IF;
    RETURN new;
  END IF;
  IF (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS DISTINCT FROM 'staged' THEN
    RAISE EXCEPTION 'places can only be removed from a staged version' USING ERRCODE = 'integrity_constraint_violation';
  END IF;
  RETURN old;
END;
$$;

CREATE TRIGGER places_staged_only BEFORE INSERT OR UPDATE OR DELETE ON places
FOR EACH ROW EXECUTE FUNCTION places_staged_only();

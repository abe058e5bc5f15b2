-- PostgreSQL migration 4: signed versions (schema/004_signatures.sql in PostgreSQL's dialect).
--
-- A version may carry one Ed25519 signature of its manifest (pl/schema/signed_manifest.hpp), made
-- by whoever publishes it with the fleet's private key: the public key (32 bytes) and the
-- signature (64 bytes), nothing secret. Written while the version is staged, just before it is
-- published (in the same transaction), read-only after; a new version never inherits its parent's.

CREATE TABLE signatures (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  map_id bigint NOT NULL,
  version bigint NOT NULL,
  public_key bytea NOT NULL CHECK (length(public_key) = 32),
  signature bytea NOT NULL CHECK (length(signature) = 64),
  signed timestamptz NOT NULL DEFAULT statement_timestamp(),
  UNIQUE (map_id, version),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

CREATE FUNCTION signatures_staged_only() RETURNS trigger LANGUAGE plpgsql AS $$
BEGIN
  IF TG_OP = 'INSERT' THEN
    IF (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS DISTINCT FROM 'staged' THEN
      RAISE EXCEPTION 'a signature can only be added to a staged version' USING ERRCODE = 'integrity_constraint_violation';
    END IF;
    RETURN new;
  END IF;
  IF TG_OP = 'UPDATE' THEN
    IF (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS DISTINCT FROM 'staged'
       OR (SELECT state FROM versions WHERE map_id = new.map_id AND number = new.version) IS DISTINCT FROM 'staged' THEN
      RAISE EXCEPTION 'a signature can only be changed in a staged version' USING ERRCODE = 'integrity_constraint_violation';
    END IF;
    RETURN new;
  END IF;
  IF (SELECT state FROM versions WHERE map_id = old.map_id AND number = old.version) IS DISTINCT FROM 'staged' THEN
    RAISE EXCEPTION 'a signature can only be removed from a staged version' USING ERRCODE = 'integrity_constraint_violation';
  END IF;
  RETURN old;
END;
$$;

CREATE TRIGGER signatures_staged_only BEFORE INSERT OR UPDATE OR DELETE ON signatures
FOR EACH ROW EXECUTE FUNCTION signatures_staged_only();

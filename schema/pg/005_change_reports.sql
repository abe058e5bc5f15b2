-- PostgreSQL migration 5: change reports from the fleet, and the report role
-- (schema/005_change_reports.sql in PostgreSQL's dialect).
--
-- A vehicle that localized against a map version sends what it saw of the map's age over one drive
-- (pl/schema/change_report.hpp); the store keeps the JSON as it was sent, one row per (map,
-- vehicle, drive): a report sent again is the same report. The store does not parse the body but
-- keeps its SHA-256, checked on read like a blob's. Reports never change (a trigger refuses
-- UPDATE); old ones are deleted (retention). They belong to an existing version of the map,
-- whatever its state.
--
-- A token may have the role 'report' (a vehicle's: it reads maps and sends reports), between read
-- and upload: the role's check constraint (named by PostgreSQL after migration 1's column) is made
-- again.

ALTER TABLE tokens DROP CONSTRAINT tokens_role_check;
ALTER TABLE tokens ADD CONSTRAINT tokens_role_check CHECK (role IN ('read', 'report', 'upload', 'admin'));

CREATE TABLE change_reports (
  id bigint GENERATED ALWAYS AS IDENTITY PRIMARY KEY,
  map_id bigint NOT NULL,
  version bigint NOT NULL,
  -- Who drove and which drive: 1 to 128 of [A-Za-z0-9_.:-], as the report's parser takes them.
  vehicle text NOT NULL CHECK (vehicle ~ '^[A-Za-z0-9_.:-]{1,128}$'),
  drive text NOT NULL CHECK (drive ~ '^[A-Za-z0-9_.:-]{1,128}$'),
  -- The drive's span as the report says, seconds since 1970.
  start_s double precision NOT NULL,
  end_s double precision NOT NULL,
  -- SHA-256 of the body, lowercase hex.
  hash text NOT NULL CHECK (hash ~ '^[0-9a-f]{64}$'),
  body bytea NOT NULL,
  size bigint NOT NULL CHECK (size > 0 AND size = length(body)),
  received timestamptz NOT NULL DEFAULT statement_timestamp(),
  -- Who sent it, as the upload log names them ("token 7").
  who text NOT NULL CHECK (length(who) > 0),
  -- Finite (NaN sorts above every number, so start_s <= end_s < 'Infinity' refuses it too).
  CHECK (start_s > '-Infinity' AND end_s < 'Infinity' AND start_s <= end_s),
  UNIQUE (map_id, vehicle, drive),
  FOREIGN KEY (map_id, version) REFERENCES versions (map_id, number)
);

-- A map's reports by version, in the order received (and the foreign key's lookups).
CREATE INDEX change_reports_version ON change_reports (map_id, version, id);

CREATE TRIGGER change_reports_no_update BEFORE UPDATE ON change_reports
FOR EACH ROW EXECUTE FUNCTION pl_refuse('change reports never change: rows cannot be updated');

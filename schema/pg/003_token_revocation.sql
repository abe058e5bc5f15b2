-- Migration 3: tokens can be revoked (schema/003_token_revocation.sql in PostgreSQL's dialect).
--
-- A revoked token keeps its row (the upload log names tokens by id, "token 7") with the time it
-- was revoked; only a token whose `revoked` is NULL opens the API. Every replica sees a revocation
-- at its next request: no restart.
ALTER TABLE tokens ADD COLUMN revoked timestamptz;

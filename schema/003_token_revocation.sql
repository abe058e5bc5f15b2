-- Migration 3: tokens can be revoked.
--
-- A revoked token keeps its row (the upload log names tokens by id, "token 7") with the time it
-- was revoked (UTC ISO 8601, as every timestamp); only a token whose `revoked` is NULL opens the
-- API. Every server on the store sees a revocation at its next request: no restart.
ALTER TABLE tokens ADD COLUMN revoked TEXT;

-- A study's tuple pool is written in chunks, one transaction each, so that the answer path is
-- not held up (issue 16). status: 'creating' while they are written (workers cannot start),
-- 'ready' once the last chunk committed, 'failed' when the creation stopped (pool_error says
-- why; its rows are then deleted in chunks). pool_done of pool_total rows (tuples and slots)
-- are written, each chunk adding its own in its transaction; pool_beat is the time of the last
-- chunk (Unix ms): a creation without one for minutes has died. Earlier studies are complete.
ALTER TABLE studies ADD COLUMN status TEXT NOT NULL DEFAULT 'ready';
ALTER TABLE studies ADD COLUMN pool_done BIGINT NOT NULL DEFAULT 0;
ALTER TABLE studies ADD COLUMN pool_total BIGINT NOT NULL DEFAULT 0;
ALTER TABLE studies ADD COLUMN pool_beat BIGINT;
ALTER TABLE studies ADD COLUMN pool_error TEXT;

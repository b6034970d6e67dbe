-- Style exploration results (Garces et al. 2016 §6.5): a taxonomy (representative styles) or a
-- style map (t-SNE positions) of a library under a model (NULL: uniform weights), computed as a
-- background job by the server that received the request and read from here by every server.
-- kind: 'taxonomy' | 'map'. params: the request's canonical JSON (identical requests on the same
-- library state reuse the row). library_items: the library's item count when the job began
-- (items are only added, so a larger library recomputes). status: 'queued' -> 'running' ->
-- 'done' | 'failed'. heartbeat_at: refreshed with the progress about every 0.5 s while the job
-- runs; a queued/running row whose heartbeat is older than a minute belongs to a dead server.
CREATE TABLE explorations (
    id BIGINT PRIMARY KEY,
    library_id BIGINT NOT NULL REFERENCES libraries(id),
    model_id BIGINT REFERENCES models(id),
    kind TEXT NOT NULL,
    params TEXT NOT NULL,
    library_items BIGINT NOT NULL,
    status TEXT NOT NULL,
    progress_done BIGINT NOT NULL,
    progress_total BIGINT NOT NULL,
    stage TEXT NOT NULL,
    error TEXT,
    result TEXT,
    created_at BIGINT NOT NULL,
    heartbeat_at BIGINT NOT NULL,
    finished_at BIGINT
);
CREATE INDEX explorations_lookup ON explorations (library_id, kind, params);

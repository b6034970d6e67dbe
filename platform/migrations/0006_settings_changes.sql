-- Changes of a study's settings after creation (`platform study edit`, the admin page, the
-- JSON API's PATCH): one row per changed field with its old and new value as JSON text, who
-- made it (`admin:NAME` or `cli`) and when, so exports and QC decisions can be read against the
-- settings that were in force.
CREATE TABLE settings_changes (
    id BIGINT PRIMARY KEY,
    study_id BIGINT NOT NULL REFERENCES studies(id),
    field TEXT NOT NULL,
    old_value TEXT NOT NULL,
    new_value TEXT NOT NULL,
    actor TEXT NOT NULL,
    changed_at BIGINT NOT NULL
);
CREATE INDEX settings_changes_study ON settings_changes (study_id, changed_at);

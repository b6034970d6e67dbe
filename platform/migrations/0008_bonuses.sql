-- Bonuses an admin recorded for a worker's HIT (the study page's worker row, or the JSON API):
-- the amount in cents of the crowd platform's currency (MTurk: US dollars; Prolific: the study's
-- currency), the reason the worker is shown, who recorded it (`admin:NAME`) and when. Rows are
-- never changed or deleted, so the table is the bonuses' audit trail; the exports turn it into
-- the files MTurk (`aws mturk send-bonus`) and Prolific (bulk bonus) are paid with.
CREATE TABLE bonuses (
    id BIGINT PRIMARY KEY,
    study_id BIGINT NOT NULL REFERENCES studies(id),
    assignment_id BIGINT NOT NULL REFERENCES assignments(id),
    amount_cents BIGINT NOT NULL,
    reason TEXT NOT NULL,
    actor TEXT NOT NULL,
    created_at BIGINT NOT NULL
);
CREATE INDEX bonuses_study ON bonuses (study_id, created_at);
CREATE INDEX bonuses_assignment ON bonuses (assignment_id);

-- The icon-set study (issue 18, Garces et al. 2016 §6.6): workers find icons for a few
-- semantic labels (face, fish, flower, bird) in one style, several sets in different styles,
-- with the style explorer (condition A: the taxonomy's representative styles and a branch on
-- the balanced grid) or the search ordered by style (condition B). The report is the time per
-- set and the deletions per set, per condition. One HIT is one tray of sets (one assignment).

-- The condition of each assignment, as `mashup_conditions`: `seq` is the assignment's place in
-- the study's balanced sequence of conditions.
CREATE TABLE iconset_conditions (
    assignment_id BIGINT PRIMARY KEY REFERENCES assignments(id),
    study_id BIGINT NOT NULL REFERENCES studies(id),
    seq BIGINT NOT NULL,
    condition TEXT NOT NULL,
    UNIQUE (study_id, seq)
);

-- Condition A's explorer, computed once when the study is created (so a HIT never waits on a
-- computation): the taxonomy's representative styles of the study's labels and each one's
-- branch on the balanced grid, as JSON (`studies::iconset::explorer::Explorer`).
CREATE TABLE iconset_explorers (
    study_id BIGINT PRIMARY KEY REFERENCES studies(id),
    result TEXT NOT NULL,
    created_at BIGINT NOT NULL
);

-- Every event of an assignment, numbered from 1, with the server's time: 'open' (the worker
-- first saw the task: set 1 starts), 'search' (condition B; `detail` holds q, label and the
-- item ids returned), 'add' and 'remove' (an icon into or out of the slot `label` of set
-- `set_index`), 'finish' (set `set_index` is complete: the next one starts). Times per set and
-- deletions are computed from these rows, never taken from the client.
CREATE TABLE iconset_events (
    assignment_id BIGINT NOT NULL REFERENCES assignments(id),
    seq BIGINT NOT NULL,
    event TEXT NOT NULL,
    set_index BIGINT NOT NULL,
    label TEXT,
    item_id BIGINT REFERENCES items(id),
    detail TEXT,
    created_at BIGINT NOT NULL,
    PRIMARY KEY (assignment_id, seq)
);

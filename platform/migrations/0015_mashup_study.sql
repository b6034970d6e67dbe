-- The mash-up study (issue 17, Garces et al. 2014 §5.7.3): workers compose a scene on the
-- canvas with style-sorted results (condition A) or results in random order (condition B); the
-- report is the mean position, in the list it came from, of each piece used. One HIT is one
-- composition task (one assignment).

-- The condition of each assignment: `seq` is the assignment's place in the study's sequence of
-- conditions (balanced: the two conditions alternate within each seeded, shuffled pair), so
-- two assignments can never take the same place.
CREATE TABLE mashup_conditions (
    assignment_id BIGINT PRIMARY KEY REFERENCES assignments(id),
    study_id BIGINT NOT NULL REFERENCES studies(id),
    seq BIGINT NOT NULL,
    condition TEXT NOT NULL,
    UNIQUE (study_id, seq)
);

-- Every search the server answered for an assignment, numbered from 1 per assignment, with the
-- item ids it returned in the order shown (a JSON array): the ground truth against which a
-- logged piece's position is checked.
CREATE TABLE mashup_searches (
    assignment_id BIGINT NOT NULL REFERENCES assignments(id),
    seq BIGINT NOT NULL,
    q TEXT NOT NULL,
    category TEXT,
    results TEXT NOT NULL,
    created_at BIGINT NOT NULL,
    PRIMARY KEY (assignment_id, seq)
);

-- Every piece added to or removed from the canvas, numbered from 1 per assignment. `event`:
-- 'add' (with the search it came from and its 1-based position in that list) or 'remove'
-- (search_seq and position NULL).
CREATE TABLE mashup_events (
    assignment_id BIGINT NOT NULL REFERENCES assignments(id),
    seq BIGINT NOT NULL,
    event TEXT NOT NULL,
    item_id BIGINT NOT NULL REFERENCES items(id),
    search_seq BIGINT,
    position BIGINT,
    created_at BIGINT NOT NULL,
    PRIMARY KEY (assignment_id, seq)
);

-- The composition an assignment submitted (its document is a row of `compositions`).
CREATE TABLE mashup_submissions (
    assignment_id BIGINT PRIMARY KEY REFERENCES assignments(id),
    composition_id BIGINT NOT NULL REFERENCES compositions(id),
    submitted_at BIGINT NOT NULL
);

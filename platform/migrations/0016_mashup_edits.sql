-- The mash-up study logs the canvas's other edits beside its adds and removes (Garces et al.
-- 2014 §5.7.3; `studies::mashup::events`): 'undo' and 'redo' (the items on the canvas and the
-- background after the step), 'layer' (a piece's layer before and after) and 'background'.
-- Undo, redo and background name no item, so `item_id` becomes nullable, and `detail` holds an
-- event's fields beyond item, search_seq and position as a JSON object. SQLite cannot drop a
-- NOT NULL in place: the table is rebuilt, with the same statements on both databases.
CREATE TABLE mashup_events_v2 (
    assignment_id BIGINT NOT NULL REFERENCES assignments(id),
    seq BIGINT NOT NULL,
    event TEXT NOT NULL,
    item_id BIGINT REFERENCES items(id),
    search_seq BIGINT,
    position BIGINT,
    detail TEXT,
    created_at BIGINT NOT NULL,
    PRIMARY KEY (assignment_id, seq)
);

INSERT INTO mashup_events_v2
    (assignment_id, seq, event, item_id, search_seq, position, detail, created_at)
SELECT assignment_id, seq, event, item_id, search_seq, position, NULL, created_at
FROM mashup_events;

DROP TABLE mashup_events;

ALTER TABLE mashup_events_v2 RENAME TO mashup_events;

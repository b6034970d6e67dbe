-- The answer path asks for an assignment's first unanswered position after every answer. The
-- primary key (assignment_id, position) finds the assignment's questions, but checking `choice`
-- reads every row of the HIT; this partial index holds only the open questions, so the lookup
-- reads a few index entries and no table row (on both databases).
CREATE INDEX questions_open ON questions (assignment_id, position) WHERE choice IS NULL;

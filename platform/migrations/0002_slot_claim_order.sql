-- The slot claim asks for the first free slot of a study in (seq, replica) order. A partial
-- index over free slots only matches that ORDER BY after the study_id equality on both
-- databases (PostgreSQL does not treat `assignment_id IS NULL` as an equality for ordering), so
-- a claim reads one index entry instead of sorting every free slot.
DROP INDEX slots_free;
CREATE INDEX slots_free_order ON slots (study_id, seq, replica) WHERE assignment_id IS NULL;

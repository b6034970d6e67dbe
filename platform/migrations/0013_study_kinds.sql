-- Study kinds (issue 17): 'triplet' (the style triplets of §5.4; every study before this one),
-- 'composition-rating' (2AFC over pairs of compositions, §5.7.3: a pair is a tuple with
-- a = b, b the composition of condition A and c that of condition B, or for known-answer pairs
-- b the expected one), 'mashup' (workers compose a scene with the search, §5.7.3). The HIT,
-- slot, training, control and QC tables are shared by all kinds.
ALTER TABLE studies ADD COLUMN kind TEXT NOT NULL DEFAULT 'triplet';

-- A library's items in import order, for the search cache's freshness check (one range read of
-- the items imported since an index was built, instead of a count over the whole library: at
-- 200,000 items the count took seconds on SQLite) and for the next import sequence number.
CREATE INDEX items_library_seq ON items (library_id, seq);

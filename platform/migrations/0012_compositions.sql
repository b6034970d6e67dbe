-- Mash-up canvas (Garces et al. 2014 §5.7.3). `items.svg`: the drawing's vector source as usvg
-- re-serialised it on import (SVG files, Iconify icons), so a composition's SVG export keeps
-- the clip art as vectors; NULL for raster items and for rows imported before this migration.
ALTER TABLE items ADD COLUMN svg TEXT;

-- A composition: pieces of one library's clip art on a background, as the JSON document of
-- `platform::mashup::document` (pieces bottom to top).
CREATE TABLE compositions (
    id BIGINT PRIMARY KEY,
    library_id BIGINT NOT NULL REFERENCES libraries(id),
    name TEXT NOT NULL,
    document TEXT NOT NULL,
    created_at BIGINT NOT NULL,
    updated_at BIGINT NOT NULL
);
CREATE INDEX compositions_library ON compositions (library_id, updated_at);

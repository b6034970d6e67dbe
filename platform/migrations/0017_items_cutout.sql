-- Raster items keep their transparency for the mash-up canvas and its exports (Garces et al.
-- 2014 §5.7.3): `items.png` is the 400x400 rendering composited onto white (what the style
-- features see), so a raster piece placed on a background showed as an opaque square.
-- `cutout` is the same 400x400 rendering before that composite, an RGBA PNG; NULL for drawings
-- (their `svg` keeps the transparency) and for raster items imported before this migration.
ALTER TABLE items ADD COLUMN cutout BYTEA;

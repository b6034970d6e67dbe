-- Informed consent (a study whose settings carry a consent text asks for it before anything
-- else). consent: NULL (the study asked for none), 'agreed' or 'declined'; consent_version: the
-- first 12 hex digits of SHA-256 of the consent text shown, so that a record says which text
-- was agreed to even after the text is edited; consent_at: Unix ms. A worker who declines gets
-- an assignment with status 'declined' and no HIT.
ALTER TABLE assignments ADD COLUMN consent TEXT;
ALTER TABLE assignments ADD COLUMN consent_version TEXT;
ALTER TABLE assignments ADD COLUMN consent_at BIGINT;

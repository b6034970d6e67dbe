-- Held-out agreement of a trained model (issue 16): every answer predicted by the
-- cross-validation fold model that did not see it, at the chosen λ, for the learned and the
-- uniform metric, with 95% bootstrap intervals over workers (or tuples). JSON, the shape of
-- `train::HeldOut`; NULL for a fixed λ (no cross-validation) and for models trained before.
ALTER TABLE models ADD COLUMN held_out TEXT;

-- Style metrics trained from a study's answers (`platform train`, or the admin's Train button).
-- status: 'running' -> 'done' | 'failed'. The learner's report (index.html and its figures)
-- and model.json are stored in model_files so every server behind a load balancer serves them.
CREATE TABLE models (
    id BIGINT PRIMARY KEY,
    study_id BIGINT NOT NULL REFERENCES studies(id),
    status TEXT NOT NULL,
    message TEXT,
    started_at BIGINT NOT NULL,
    finished_at BIGINT,
    triplets BIGINT,
    lambda DOUBLE PRECISION,
    nonzero BIGINT,
    train_accuracy DOUBLE PRECISION,
    uniform_accuracy DOUBLE PRECISION,
    cv_accuracy DOUBLE PRECISION
);
CREATE INDEX models_study ON models (study_id, started_at);

CREATE TABLE model_files (
    model_id BIGINT NOT NULL REFERENCES models(id),
    name TEXT NOT NULL,
    bytes BYTEA NOT NULL,
    PRIMARY KEY (model_id, name)
);

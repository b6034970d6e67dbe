-- Failed admin logins, for throttling (kept in the database so every server behind a load
-- balancer counts the same attempts).
CREATE TABLE login_failures (
    username TEXT NOT NULL,
    at BIGINT NOT NULL
);
CREATE INDEX login_failures_user ON login_failures (username, at);

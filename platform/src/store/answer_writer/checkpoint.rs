//! The SQLite writer's checkpoints, on a thread of their own.
//!
//! In WAL mode every commit appends its pages to the `-wal` file, and a checkpoint copies them
//! back into the database file. SQLite's automatic checkpoint runs in the connection that
//! committed, right after its commit: in the answer writer, the one thread every answer waits
//! for. At 13,000 answers/s (about three pages each, with random tuple ids) the default of
//! 1,000 pages checkpointed dozens of times a second: 14% of the writer's CPU plus two fsyncs
//! each (`perf`, 200 closed-loop workers). A larger threshold made them rarer but each one a
//! longer stall (a worse p99). So the writer's automatic checkpoint is off, and this thread, on
//! a connection of its own, copies the pages in `PASSIVE` mode, which takes no lock the writer
//! needs: the writer goes on committing meanwhile, on the other core.
//!
//! A WAL is rewritten from its start ("restarted") only by a writer that finds every frame
//! copied and no reader on them, which a checkpoint running beside a busy writer never
//! leaves behind. So once the WAL holds [`CheckpointPlan::restart_frames`], the next
//! checkpoint runs holding the process's write turn, between two batches: it copies only the
//! few frames written since the previous checkpoint, and the writer's next transaction
//! restarts the WAL (unless a reader still holds an older snapshot; then the next round
//! tries again).
//!
//! Durability is unchanged: a checkpoint syncs the WAL before it copies and the database file
//! after (see `sqlite.rs` for why the answers are durable when their replies go out).

use std::path::Path;
use std::sync::Arc;
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender};
use std::time::Duration;

use rusqlite::Connection;

use crate::error::{AppError, Result};

/// When the checkpoint thread runs.
#[derive(Debug, Clone, Copy)]
pub(super) struct CheckpointPlan {
    /// Time between two checkpoints.
    pub interval: Duration,
    /// WAL frames (pages) from which a checkpoint is run between two of the writer's batches,
    /// so that the WAL restarts.
    pub restart_frames: i64,
}

impl Default for CheckpointPlan {
    /// Every 0.1 s; the WAL restarts once it holds 2,000 frames (~8 MB). At 200 closed-loop
    /// workers the writer appended ~40,000 frames/s (about three pages per answer: its question
    /// row, its entry in the open-questions index, and its share of a HIT start's slot claims;
    /// measured while tuple ids were random, which spread the claims), so that is every round
    /// and the WAL file stays near 4,000 frames (twice that when a reader's snapshot keeps one
    /// restart from happening); at 1,000 answers/s it is about every 0.7 s.
    fn default() -> Self {
        Self {
            interval: Duration::from_millis(100),
            restart_frames: 2_000,
        }
    }
}

/// Starts the checkpoint thread of the database file at `path`, on a connection of its own,
/// with the default plan. It stops once the returned sender is dropped (the writer holds it).
pub(super) fn spawn(path: &Path, turn: Arc<tokio::sync::Mutex<()>>) -> Result<Sender<()>> {
    let conn = crate::store::sqlite_direct::open(path)?;
    let (writer_alive, writer_gone) = std::sync::mpsc::channel();
    std::thread::Builder::new()
        .name("answer-checkpoint".into())
        .spawn(move || run(&conn, &turn, &writer_gone, CheckpointPlan::default()))
        .map_err(AppError::internal)?;
    Ok(writer_alive)
}

/// Checkpoints the database of `conn` every `plan.interval` until `writer_gone` says the writer
/// has stopped, then once more. `turn` is the process's write turn (held by each of the
/// writer's batches).
pub(super) fn run(
    conn: &Connection,
    turn: &tokio::sync::Mutex<()>,
    writer_gone: &Receiver<()>,
    plan: CheckpointPlan,
) {
    loop {
        let last = match writer_gone.recv_timeout(plan.interval) {
            Err(RecvTimeoutError::Timeout) => false,
            // The writer only ever drops its sender.
            Ok(()) | Err(RecvTimeoutError::Disconnected) => true,
        };
        match passive(conn) {
            Ok(frames) if frames >= plan.restart_frames && !last => {
                let _turn = turn.blocking_lock();
                if let Err(e) = passive(conn) {
                    eprintln!("error: checkpoint before a WAL restart: {e}");
                }
            }
            Ok(_) => {}
            Err(e) => eprintln!("error: checkpoint: {e}"),
        }
        if last {
            break;
        }
    }
}

/// One `PASSIVE` checkpoint; returns the frames in the WAL (copied or not).
fn passive(conn: &Connection) -> Result<i64> {
    // Columns: busy (always 0 in PASSIVE mode), frames in the WAL, frames copied.
    Ok(conn.query_row("PRAGMA wal_checkpoint(PASSIVE)", [], |r| r.get(1))?)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::store::sqlite_direct::execute;

    /// A WAL frame: a 24-byte header and a 4,096-byte page (SQLite's default page size).
    const FRAME_BYTES: u64 = 24 + 4_096;

    /// The salts of the WAL header, which change each time the WAL restarts.
    fn wal_salts(wal: &std::path::Path) -> Option<[u8; 8]> {
        use std::io::Read;
        let mut header = [0u8; 24];
        std::fs::File::open(wal)
            .ok()?
            .read_exact(&mut header)
            .ok()?;
        header[16..24].try_into().ok()
    }

    /// A writer committing one ~3 KB row per transaction, without automatic checkpoints, each
    /// transaction holding the write turn as the answer writer's batches do, beside the
    /// checkpoint thread (10 ms rounds, restart from 100 frames). A checkpoint beside it never
    /// leaves every frame copied, so the WAL restarts only through the checkpoint taken
    /// between two transactions.
    struct BusyWriter {
        dir: tempfile::TempDir,
        writer: Connection,
        turn: Arc<tokio::sync::Mutex<()>>,
        alive: Sender<()>,
        thread: std::thread::JoinHandle<()>,
        rows: i64,
        salts: Option<[u8; 8]>,
    }

    impl BusyWriter {
        fn start() -> Self {
            let dir = tempfile::tempdir().expect("temp dir");
            let path = dir.path().join("c.db");
            rusqlite::Connection::open(&path).expect("create");
            let writer = crate::store::sqlite_direct::open(&path).expect("open");
            writer
                .pragma_update(None, "wal_autocheckpoint", 0)
                .expect("pragma");
            // As the answer writer: the commit writes the WAL, its fsync happens elsewhere.
            writer
                .pragma_update(None, "synchronous", "NORMAL")
                .expect("pragma");
            execute(
                &writer,
                "CREATE TABLE t (id INTEGER PRIMARY KEY, v BLOB)",
                &[],
            )
            .expect("table");
            let turn = Arc::new(tokio::sync::Mutex::new(()));
            let plan = CheckpointPlan {
                interval: Duration::from_millis(10),
                restart_frames: 100,
            };
            let (alive, gone) = std::sync::mpsc::channel();
            let checkpoints = crate::store::sqlite_direct::open(&path).expect("open");
            let thread_turn = turn.clone();
            let thread = std::thread::spawn(move || run(&checkpoints, &thread_turn, &gone, plan));
            Self {
                dir,
                writer,
                turn,
                alive,
                thread,
                rows: 0,
                salts: None,
            }
        }

        fn path(&self, file: &str) -> std::path::PathBuf {
            self.dir.path().join(file)
        }

        /// Commits until at least `restarts` WAL restarts (counted by the header's salts) and
        /// `rows` rows, or until `limit` is over (generous: the checkpoint's fsyncs are slow
        /// on a busy disk); returns the restarts seen.
        fn commit_until(&mut self, restarts: usize, rows: i64, limit: Duration) -> usize {
            let deadline = std::time::Instant::now() + limit;
            let (mut seen, mut written) = (0, 0);
            while (seen < restarts || written < rows) && std::time::Instant::now() < deadline {
                let turn = self.turn.blocking_lock();
                execute(&self.writer, "BEGIN IMMEDIATE", &[]).expect("begin");
                execute(
                    &self.writer,
                    "INSERT INTO t (id, v) VALUES ($1, zeroblob(3000))",
                    &[&self.rows],
                )
                .expect("insert");
                execute(&self.writer, "COMMIT", &[]).expect("commit");
                drop(turn);
                self.rows += 1;
                written += 1;
                let now = wal_salts(&self.path("c.db-wal"));
                if self.salts.is_some() && now != self.salts {
                    seen += 1;
                }
                self.salts = now;
            }
            seen
        }

        /// Stops the checkpoint thread and checks that every row committed is in the database.
        fn finish(self) {
            drop(self.alive);
            self.thread.join().expect("checkpoint thread");
            drop(self.writer);
            let check = rusqlite::Connection::open(self.dir.path().join("c.db")).expect("reopen");
            let n: i64 = check
                .query_row("SELECT count(*) FROM t", [], |r| r.get(0))
                .expect("count");
            assert_eq!(n, self.rows);
        }
    }

    /// With the checkpoint thread, the WAL of a writer that never pauses restarts again and
    /// again.
    #[test]
    fn the_wal_restarts_under_a_busy_writer() {
        let mut busy = BusyWriter::start();
        let restarts = busy.commit_until(5, 1_000, Duration::from_secs(30));
        assert!(
            restarts >= 5,
            "{restarts} WAL restarts in {} transactions",
            busy.rows
        );
        busy.finish();
    }

    /// A reader holding one snapshot (a long export) keeps the checkpoints from copying the
    /// frames written after it, so the WAL grows while it lasts (at most one restart, when the
    /// snapshot read the database file alone); once it ends the WAL restarts again.
    #[test]
    fn a_long_reader_delays_wal_restarts_until_it_ends() {
        let mut busy = BusyWriter::start();
        assert!(busy.commit_until(1, 0, Duration::from_secs(30)) >= 1);

        let reader = crate::store::sqlite_direct::open(&busy.path("c.db")).expect("open");
        execute(&reader, "BEGIN", &[]).expect("begin");
        let count = || -> i64 {
            reader
                .query_row("SELECT count(*) FROM t", [], |r| r.get(0))
                .expect("count")
        };
        let before = count();
        let held = 400;
        let restarts = busy.commit_until(0, held, Duration::from_secs(30));
        assert!(restarts <= 1, "{restarts} WAL restarts under a reader");
        let wal_bytes = std::fs::metadata(busy.path("c.db-wal")).expect("wal").len();
        // Each transaction appends at least its new leaf page.
        assert!(
            wal_bytes >= 32 + held as u64 * FRAME_BYTES,
            "the WAL held {wal_bytes} bytes after {held} transactions under a reader"
        );
        assert_eq!(count(), before, "the reader keeps its snapshot");
        execute(&reader, "COMMIT", &[]).expect("end the read");

        let restarts = busy.commit_until(3, 0, Duration::from_secs(30));
        assert!(restarts >= 3, "{restarts} WAL restarts after the reader");
        busy.finish();
    }
}

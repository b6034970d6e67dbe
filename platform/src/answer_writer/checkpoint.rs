//! The SQLite writer's checkpoints, on a thread of their own.
//!
//! In WAL mode every commit appends its pages to the `-wal` file, and a checkpoint copies them
//! back into the database file. SQLite's automatic checkpoint runs in the connection that
//! committed, right after its commit: in the answer writer, the one thread every answer waits
//! for. At 13,000 answers/s (about three pages each) the default of 1,000 pages checkpointed
//! dozens of times a second: 14% of the writer's CPU plus two fsyncs each (`perf`, 200
//! closed-loop workers). A larger threshold made them rarer but each one a longer stall (a
//! worse p99). So the writer's automatic checkpoint is off, and this thread, on a connection of
//! its own, copies the pages in `PASSIVE` mode, which takes no lock the writer needs: the
//! writer goes on committing meanwhile, on the other core.
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
    /// workers the writer appends ~40,000 frames/s (about three pages per answer: its question
    /// row, its entry in the open-questions index, and its share of a HIT start's slot
    /// claims), so that is every round and the WAL file stays near 4,000 frames (twice that
    /// when a reader's snapshot keeps one restart from happening); at 1,000 answers/s it is
    /// about every 0.7 s.
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
    let conn = crate::sqlite_direct::open(path)?;
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
    use crate::sqlite_direct::execute;

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

    /// A writer committing without pause and without automatic checkpoints, each transaction
    /// holding the turn: a checkpoint beside it never leaves every frame copied, so the WAL
    /// restarts only through the checkpoint taken between two transactions. With the
    /// checkpoint thread it restarts again and again (counted by its header's salts; the time
    /// limit is generous because the checkpoint's fsyncs are slow on a busy disk), and every
    /// row is in the database afterwards.
    #[test]
    fn the_wal_restarts_under_a_busy_writer() {
        let dir = tempfile::tempdir().expect("temp dir");
        let path = dir.path().join("c.db");
        rusqlite::Connection::open(&path).expect("create");
        let writer = crate::sqlite_direct::open(&path).expect("open");
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
        let turn = std::sync::Arc::new(tokio::sync::Mutex::new(()));
        let plan = CheckpointPlan {
            interval: Duration::from_millis(10),
            restart_frames: 100,
        };
        let (alive, gone) = std::sync::mpsc::channel();
        let checkpoints = crate::sqlite_direct::open(&path).expect("open");
        let thread_turn = turn.clone();
        let thread = std::thread::spawn(move || run(&checkpoints, &thread_turn, &gone, plan));
        let wal = dir.path().join("c.db-wal");
        let deadline = std::time::Instant::now() + Duration::from_secs(30);
        let (mut rows, mut restarts, mut salts) = (0_i64, 0, None);
        while (restarts < 5 || rows < 1_000) && std::time::Instant::now() < deadline {
            let _turn = turn.blocking_lock();
            execute(&writer, "BEGIN IMMEDIATE", &[]).expect("begin");
            execute(
                &writer,
                "INSERT INTO t (id, v) VALUES ($1, zeroblob(3000))",
                &[&rows],
            )
            .expect("insert");
            execute(&writer, "COMMIT", &[]).expect("commit");
            drop(_turn);
            rows += 1;
            let now = wal_salts(&wal);
            if salts.is_some() && now != salts {
                restarts += 1;
            }
            salts = now;
        }
        drop(alive);
        thread.join().expect("checkpoint thread");
        assert!(
            restarts >= 5,
            "{restarts} WAL restarts in {rows} transactions"
        );
        drop(writer);
        let check = rusqlite::Connection::open(&path).expect("reopen");
        let n: i64 = check
            .query_row("SELECT count(*) FROM t", [], |r| r.get(0))
            .expect("count");
        assert_eq!(n, rows);
    }
}

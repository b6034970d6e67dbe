//! Requests that the SQLite writer writes together, one call for all of a batch's requests of
//! one kind, inside its transaction. The writer owns the transaction, the batching and the
//! durable acknowledgement; *what* is written belongs to the module that implements
//! [`Batched`] (the worker flow's answers), so the store knows none of its types.
//!
//! Requests of different kinds share the writer's queue, so each is erased to an [`Entry`]
//! keyed by its kind's `TypeId`; the entries of one kind are turned back into their types and
//! handed to the kind in one call.

use std::any::{Any, TypeId};

use rusqlite::Connection;
use tokio::sync::oneshot;

use super::Deliver;
use crate::error::{AppError, Result};

/// A kind of request the writer batches: every request of a batch is written by one call of
/// [`Batched::write`], in arrival order, inside the writer's open transaction (which the
/// implementation must neither begin nor end).
pub trait Batched: Sync + 'static {
    /// What a caller hands over.
    type Request: Send + 'static;
    /// What a caller gets back, once the transaction is committed and durable.
    type Reply: Send + 'static;

    /// Writes `requests`. The outer `Err` aborts the whole batch (a database failure: nobody
    /// is acknowledged, and every caller gets an error); an inner `Err` refuses that request
    /// only, and must leave nothing of it written.
    fn write(
        &self,
        conn: &Connection,
        requests: &[Self::Request],
    ) -> Result<Vec<Result<Self::Reply>>>;
}

/// One queued request of some [`Batched`] kind.
pub(super) trait Entry: Send {
    /// The kind's type: the entries of one kind are written in one call.
    fn kind(&self) -> TypeId;
    /// For turning the other entries of this kind back into their type.
    fn into_any(self: Box<Self>) -> Box<dyn Any + Send>;
    /// Answers the caller with `error` instead of writing (a request that reached the wrong
    /// writer).
    fn refuse(self: Box<Self>, error: AppError);
    /// Writes this entry and `same` (entries of the same kind, in arrival order) and returns
    /// what to deliver once the transaction's fate is known. On `Err` the callers have been
    /// told and the batch must be aborted.
    fn write_with(self: Box<Self>, same: Vec<Box<dyn Entry>>, conn: &Connection)
    -> Result<Deliver>;
}

/// A request and its caller's reply channel.
pub(super) struct Typed<B: Batched> {
    pub(super) kind: &'static B,
    pub(super) request: B::Request,
    pub(super) reply: oneshot::Sender<Result<B::Reply>>,
}

impl<B: Batched> Entry for Typed<B> {
    fn kind(&self) -> TypeId {
        TypeId::of::<B>()
    }

    fn into_any(self: Box<Self>) -> Box<dyn Any + Send> {
        self
    }

    fn refuse(self: Box<Self>, error: AppError) {
        let _ = self.reply.send(Err(error));
    }

    fn write_with(
        self: Box<Self>,
        same: Vec<Box<dyn Entry>>,
        conn: &Connection,
    ) -> Result<Deliver> {
        let kind = self.kind;
        let mut requests = Vec::with_capacity(same.len() + 1);
        let mut replies = Vec::with_capacity(same.len() + 1);
        let Typed { request, reply, .. } = *self;
        requests.push(request);
        replies.push(reply);
        for entry in same {
            // Grouped by `kind()`, the `TypeId` of `B`: the downcast cannot fail.
            let Ok(entry) = entry.into_any().downcast::<Typed<B>>() else {
                return Err(AppError::Internal(
                    "a batched request was grouped with another kind".into(),
                ));
            };
            let Typed { request, reply, .. } = *entry;
            requests.push(request);
            replies.push(reply);
        }
        let written = match kind.write(conn, &requests) {
            Ok(w) if w.len() == replies.len() => w,
            Ok(w) => {
                let why = format!("{} outcomes for {} requests", w.len(), replies.len());
                fail(replies, &why);
                return Err(AppError::Internal(why));
            }
            Err(e) => {
                fail(replies, &e.to_string());
                return Err(e);
            }
        };
        Ok(Box::new(move |committed| match committed {
            Ok(()) => {
                for (reply, outcome) in replies.into_iter().zip(written) {
                    // The caller may have gone (client disconnected): nothing to do.
                    let _ = reply.send(outcome);
                }
            }
            Err(why) => {
                for reply in replies {
                    let _ = reply.send(Err(AppError::Internal(format!(
                        "the request could not be made durable: {why}"
                    ))));
                }
            }
        }))
    }
}

/// Tells every caller that their request was not stored (or not made durable).
fn fail<T>(replies: Vec<oneshot::Sender<Result<T>>>, why: &str) {
    for reply in replies {
        let _ = reply.send(Err(AppError::Internal(format!(
            "storing the request failed: {why}"
        ))));
    }
}

/// Splits `entries` into runs of one kind each, in the order each kind first arrived (entries
/// keep their arrival order within their kind).
pub(super) fn by_kind(entries: Vec<Box<dyn Entry>>) -> Vec<Vec<Box<dyn Entry>>> {
    let mut groups: Vec<(TypeId, Vec<Box<dyn Entry>>)> = Vec::new();
    for entry in entries {
        let kind = entry.kind();
        match groups.iter_mut().find(|(k, _)| *k == kind) {
            Some((_, group)) => group.push(entry),
            None => groups.push((kind, vec![entry])),
        }
    }
    groups.into_iter().map(|(_, group)| group).collect()
}

//! The bounded heap of the exact scan: the `k` smallest `(key, row)` pairs, ties by row so the
//! result is the same however the rows are split across threads.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

/// A heap entry: ordered by key, then row (so ties go to the earlier item).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Entry {
    key: f32,
    row: u32,
}

impl Eq for Entry {}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        self.key
            .total_cmp(&other.key)
            .then(self.row.cmp(&other.row))
    }
}

/// The `k` smallest `(key, row)` pairs seen, in a max-heap.
#[derive(Debug, Clone)]
pub(crate) struct TopK {
    k: usize,
    heap: BinaryHeap<Entry>,
}

impl TopK {
    pub(crate) fn new(k: usize) -> Self {
        Self {
            k,
            heap: BinaryHeap::with_capacity(k + 1),
        }
    }

    fn is_full(&self) -> bool {
        self.heap.len() >= self.k
    }

    /// Keys above this cannot enter.
    #[inline]
    pub(crate) fn threshold(&self) -> f32 {
        if self.is_full() {
            self.heap.peek().map_or(f32::INFINITY, |e| e.key)
        } else {
            f32::INFINITY
        }
    }

    #[inline]
    pub(crate) fn push(&mut self, key: f32, row: u32) {
        let e = Entry { key, row };
        if !self.is_full() {
            self.heap.push(e);
        } else if self.heap.peek().is_some_and(|top| e < *top) {
            self.heap.pop();
            self.heap.push(e);
        }
    }

    pub(crate) fn merge(mut self, other: Self) -> Self {
        for e in other.heap {
            self.push(e.key, e.row);
        }
        self
    }

    /// `(key, row)`, smallest first.
    pub(crate) fn into_sorted(self) -> Vec<(f32, u32)> {
        self.heap
            .into_sorted_vec()
            .into_iter()
            .map(|e| (e.key, e.row))
            .collect()
    }
}

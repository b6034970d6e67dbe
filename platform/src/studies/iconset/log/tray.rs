//! The tray of an icon-set HIT as its log says (pure): what a worker may do ([`Action`]), the
//! stored events ([`Logged`]), the tray replayed from them ([`replay`]) with each set's start,
//! finish, deletions and searches, the check of the next step ([`check`]), and a finished set's
//! style spread ([`spread`]).

use serde::{Deserialize, Serialize};
use utoipa::ToSchema;

use super::super::IconsetSettings;
use crate::error::{AppError, Result};
use crate::search::cache::Built;
use crate::store::db::now_ms;
use crate::store::ids::ItemId;

/// What a worker does to the tray.
#[derive(Debug, Clone, PartialEq, Eq, Deserialize, ToSchema)]
#[serde(tag = "event", rename_all = "lowercase", deny_unknown_fields)]
pub enum Action {
    /// Puts an icon into the current set, in the slot of its label (which must be empty).
    Add {
        /// The icon (an item of the study's library with one of the study's labels).
        item: ItemId,
    },
    /// Takes the icon out of the slot `label` of the current set (a deletion).
    Remove {
        /// The slot's label.
        #[schema(max_length = 200)]
        label: String,
    },
    /// Finishes the current set (every slot filled); the next set starts.
    Finish,
}

/// A stored event's kind.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// The worker first opened the task: set 1 starts.
    Open,
    /// A search answered (condition B).
    Search,
    /// An icon put into a slot.
    Add,
    /// An icon taken out of a slot.
    Remove,
    /// A set finished.
    Finish,
}

impl Kind {
    /// As stored in `iconset_events.event`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Open => "open",
            Self::Search => "search",
            Self::Add => "add",
            Self::Remove => "remove",
            Self::Finish => "finish",
        }
    }

    /// As stored; anything else is an internal error (only this module writes it).
    pub(super) fn from_stored(s: &str) -> Result<Self> {
        [
            Self::Open,
            Self::Search,
            Self::Add,
            Self::Remove,
            Self::Finish,
        ]
        .into_iter()
        .find(|k| k.as_str() == s)
        .ok_or_else(|| AppError::Internal(format!("iconset_events: unknown event {s:?}")))
    }
}

/// A stored event.
#[derive(Debug, Clone, PartialEq)]
pub struct Logged {
    /// Its kind.
    pub kind: Kind,
    /// The set it belongs to, from 1.
    pub set: usize,
    /// The slot's label (add, remove).
    pub label: Option<String>,
    /// The icon (add, remove).
    pub item: Option<ItemId>,
    /// Server time, Unix ms.
    pub at: i64,
    /// finish: the set's style spread ([`spread`]), when its icons are in the index.
    pub spread: Option<f64>,
}

/// One set of the tray, as the log says.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct SetState {
    /// Its number, from 1.
    pub index: usize,
    /// The icon in each slot, in the order of the study's labels.
    pub slots: Vec<Option<ItemId>>,
    /// When it started (Unix ms; `None`: not yet).
    pub started_at: Option<i64>,
    /// When it was finished (Unix ms; `None`: not yet).
    pub finished_at: Option<i64>,
    /// Icons removed from it.
    pub deletions: usize,
    /// Searches made while it was the current set.
    pub searches: usize,
    /// Its style spread when it was finished: the mean style distance `d` (Garces et al. 2014
    /// eq. 5.5, under the study's model) between two of its icons ([`spread`]).
    pub spread: Option<f64>,
}

impl SetState {
    /// Whether every slot holds an icon.
    pub fn full(&self) -> bool {
        self.slots.iter().all(Option::is_some)
    }

    /// Milliseconds from its start to its end, when finished.
    pub fn duration_ms(&self) -> Option<i64> {
        Some(self.finished_at? - self.started_at?)
    }
}

/// The tray of sets.
#[derive(Debug, Clone, PartialEq, Serialize, ToSchema)]
pub struct Tray {
    /// The sets, in order.
    pub sets: Vec<SetState>,
}

impl Tray {
    /// The index (0-based) of the set being made: the first not finished; `None` when every
    /// set is finished.
    pub fn current(&self) -> Option<usize> {
        self.sets.iter().position(|s| s.finished_at.is_none())
    }

    /// The set (1-based) holding `item`, if any.
    pub fn holding(&self, item: ItemId) -> Option<usize> {
        self.sets
            .iter()
            .find(|s| s.slots.contains(&Some(item)))
            .map(|s| s.index)
    }
}

/// Replays `events` into a tray of `sets` sets of `labels`' slots.
pub fn replay(labels: &[String], sets: u32, events: &[Logged]) -> Tray {
    let mut tray = Tray {
        sets: (1..=sets as usize)
            .map(|index| SetState {
                index,
                slots: vec![None; labels.len()],
                started_at: None,
                finished_at: None,
                deletions: 0,
                searches: 0,
                spread: None,
            })
            .collect(),
    };
    for e in events {
        let Some(set) = tray.sets.get_mut(e.set.wrapping_sub(1)) else {
            continue;
        };
        let slot = e
            .label
            .as_ref()
            .and_then(|l| labels.iter().position(|x| x == l));
        match e.kind {
            Kind::Open => {
                set.started_at.get_or_insert(e.at);
            }
            Kind::Search => set.searches += 1,
            Kind::Add => {
                if let Some(s) = slot {
                    set.slots[s] = e.item;
                }
            }
            Kind::Remove => {
                if let Some(s) = slot {
                    set.slots[s] = None;
                }
                set.deletions += 1;
            }
            Kind::Finish => {
                set.finished_at = Some(e.at);
                set.spread = e.spread;
                if let Some(next) = tray.sets.get_mut(e.set) {
                    next.started_at = Some(e.at);
                }
            }
        }
    }
    tray
}

/// Checks `action` against `tray` (the item's label already looked up as `item_label`);
/// returns the event to store.
pub fn check(
    settings: &IconsetSettings,
    tray: &Tray,
    action: &Action,
    item_label: Option<&str>,
) -> Result<Logged> {
    let Some(current) = tray.current() else {
        return Err(AppError::Conflict(
            "every set is finished: submit the tray".into(),
        ));
    };
    let set = &tray.sets[current];
    let at = now_ms();
    match action {
        Action::Add { item } => {
            let label = item_label.unwrap_or_default();
            let Some(slot) = settings.slot(label) else {
                return Err(AppError::BadRequest(format!(
                    "item {item} is labelled {label:?}, not one of this task's labels ({})",
                    settings.labels.join(", ")
                )));
            };
            if let Some(other) = tray.holding(*item) {
                return Err(AppError::BadRequest(format!(
                    "item {item} is already in set {other}: each icon goes into one set"
                )));
            }
            if set.slots[slot].is_some() {
                return Err(AppError::BadRequest(format!(
                    "the {label} of set {} is chosen: remove it first",
                    set.index
                )));
            }
            Ok(Logged {
                kind: Kind::Add,
                set: set.index,
                label: Some(label.to_owned()),
                item: Some(*item),
                at,
                spread: None,
            })
        }
        Action::Remove { label } => {
            let Some(slot) = settings.slot(label) else {
                return Err(AppError::BadRequest(format!(
                    "label: {:?} is not one of this task's labels ({})",
                    label.chars().take(40).collect::<String>(),
                    settings.labels.join(", ")
                )));
            };
            let Some(item) = set.slots[slot] else {
                return Err(AppError::BadRequest(format!(
                    "the {label} of set {} is empty: nothing to remove",
                    set.index
                )));
            };
            Ok(Logged {
                kind: Kind::Remove,
                set: set.index,
                label: Some(label.clone()),
                item: Some(item),
                at,
                spread: None,
            })
        }
        Action::Finish => {
            if !set.full() {
                let missing: Vec<&str> = settings
                    .labels
                    .iter()
                    .zip(&set.slots)
                    .filter(|(_, s)| s.is_none())
                    .map(|(l, _)| l.as_str())
                    .collect();
                return Err(AppError::BadRequest(format!(
                    "set {} still needs: {}",
                    set.index,
                    missing.join(", ")
                )));
            }
            Ok(Logged {
                kind: Kind::Finish,
                set: set.index,
                label: None,
                item: None,
                at,
                spread: None,
            })
        }
    }
}

/// The style spread of a set: the mean style distance `d` (Garces et al. 2014 eq. 5.5: the
/// Euclidean distance between rows of `√w ⊙ x̂`, the search's distance) over every pair of its
/// icons, in `built`'s space; `None` with fewer than two icons or an icon not in the index. A
/// set "in one style" has a small spread; the report compares it between conditions.
pub fn spread(built: &Built, items: &[ItemId]) -> Option<f64> {
    let rows: Vec<usize> = items
        .iter()
        .map(|&i| built.row_of(i))
        .collect::<Option<_>>()?;
    let matrix = built.index.matrix();
    let (mut sum, mut pairs) = (0.0, 0usize);
    for (k, &a) in rows.iter().enumerate() {
        for &b in &rows[k + 1..] {
            sum += matrix.distance_to(a, matrix.row(b));
            pairs += 1;
        }
    }
    (pairs > 0).then(|| sum / pairs as f64)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn settings() -> IconsetSettings {
        IconsetSettings {
            labels: vec!["fish".into(), "bird".into()],
            sets: 2,
            ..IconsetSettings::default()
        }
    }

    fn ev(kind: Kind, set: usize, label: Option<&str>, item: Option<i64>, at: i64) -> Logged {
        Logged {
            kind,
            set,
            label: label.map(str::to_owned),
            item: item.map(ItemId),
            at,
            spread: None,
        }
    }

    #[test]
    fn replay_times_sets_from_the_open_and_each_finish_and_counts_deletions() {
        let s = settings();
        let log = [
            ev(Kind::Open, 1, None, None, 1_000),
            ev(Kind::Add, 1, Some("fish"), Some(10), 2_000),
            ev(Kind::Add, 1, Some("bird"), Some(11), 3_000),
            ev(Kind::Remove, 1, Some("bird"), Some(11), 4_000),
            ev(Kind::Add, 1, Some("bird"), Some(12), 5_000),
            ev(Kind::Finish, 1, None, None, 6_500),
            ev(Kind::Search, 2, Some("fish"), None, 7_000),
            ev(Kind::Add, 2, Some("fish"), Some(20), 8_000),
        ];
        let t = replay(&s.labels, s.sets, &log);
        assert_eq!(t.current(), Some(1));
        assert_eq!(t.sets[0].slots, vec![Some(ItemId(10)), Some(ItemId(12))]);
        assert_eq!(
            (t.sets[0].duration_ms(), t.sets[0].deletions),
            (Some(5_500), 1)
        );
        assert_eq!(t.sets[1].started_at, Some(6_500));
        assert_eq!((t.sets[1].searches, t.sets[1].duration_ms()), (1, None));
        assert_eq!(t.holding(ItemId(10)), Some(1));
        assert_eq!(t.holding(ItemId(11)), None);

        // What may happen next.
        let add = |item| Action::Add { item: ItemId(item) };
        assert!(check(&s, &t, &add(10), Some("fish")).is_err(), "in set 1");
        assert!(check(&s, &t, &add(21), Some("fish")).is_err(), "slot taken");
        assert!(
            check(&s, &t, &add(21), Some("face")).is_err(),
            "not a label"
        );
        assert!(check(&s, &t, &add(21), None).is_err(), "unlabelled");
        assert!(
            check(&s, &t, &Action::Finish, None).is_err(),
            "bird missing"
        );
        let remove = |l: &str| Action::Remove { label: l.into() };
        assert!(check(&s, &t, &remove("bird"), None).is_err(), "empty slot");
        assert!(check(&s, &t, &remove("cat"), None).is_err(), "no such slot");
        let e = check(&s, &t, &add(21), Some("bird")).unwrap();
        assert_eq!((e.kind, e.set, e.item), (Kind::Add, 2, Some(ItemId(21))));
        let e = check(&s, &t, &remove("fish"), None).unwrap();
        assert_eq!((e.kind, e.item), (Kind::Remove, Some(ItemId(20))));
    }

    #[test]
    fn nothing_is_accepted_after_the_last_set() {
        let s = settings();
        let mut log = vec![ev(Kind::Open, 1, None, None, 0)];
        for set in 1..=2 {
            log.push(ev(Kind::Add, set, Some("fish"), Some(set as i64), 1));
            log.push(ev(Kind::Add, set, Some("bird"), Some(10 + set as i64), 2));
            log.push(ev(Kind::Finish, set, None, None, 3));
        }
        let t = replay(&s.labels, s.sets, &log);
        assert_eq!(t.current(), None);
        let e = check(&s, &t, &Action::Finish, None).unwrap_err();
        assert!(matches!(e, AppError::Conflict(_)), "{e:?}");
    }
}

//! What the queryable's callback answers itself, without the trip
//! through the event loop (see the parent module).

use super::{lock, Event, Follow, Follows, Own};
use crate::cmd::{Apply, Params, Request};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::Root;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use zenoh::bytes::Encoding;
use zenoh::query::Query;

/// What the queryable's callback may answer itself, without the trip
/// through the event loop: it is asked only when no request or put is
/// queued or being handled, so a client's request still comes after
/// everything it sent before it. Anything else, and a request that fails,
/// goes the usual way.
pub(super) struct Quick {
    pub(super) store: Arc<Mutex<Store>>,
    pub(super) root: Root,
    /// Follow-ups queued for the task (the server's `follows`).
    pub(super) follows: Arc<Follows>,
    /// Set, under the store's lock, while the loop holds answers to
    /// changes not yet synced to disk (group commit): a read answered here
    /// then could show a change that a crash would lose.
    pub(super) unsynced: Arc<AtomicBool>,
    /// Changes too (`set`, `signal`, a `wait` granted at once, `ack`), when
    /// the store is in memory: what is left to do (publication, grants)
    /// goes to the event loop, ahead of anything queued; and whether the
    /// loop's clock is a lock-step one.
    pub(super) writes: Option<(flume::Sender<Event>, bool)>,
}

impl Quick {
    /// Answers a plain read (`var/<name>`, `sem/<name>`), a `set`, a
    /// `signal`, a `wait` that takes a unit at once or an `ack`.
    pub(super) fn answer(&self, query: &Query) -> bool {
        let key = query.key_expr().as_str();
        if key.contains('*') {
            return false;
        }
        let params = Params::new(query.parameters().iter());
        let payload = query.payload().map(|p| p.to_bytes());
        // Set when a follow-up was queued: the task is woken once the
        // answer is on its way.
        let mut wake = None;
        let applied = match Request::parse(&self.root, key, params, payload.as_deref()) {
            Ok(request @ (Request::Get(_) | Request::Read(_))) => {
                let mut store = lock(&self.store);
                if self.unsynced.load(Ordering::SeqCst) {
                    return false;
                }
                request.apply(&mut store, Instant::now())
            }
            Ok(
                request @ (Request::Set(_)
                | Request::Signal(_)
                | Request::Wait(_)
                | Request::Ack(_)),
            ) => match &self.writes {
                Some((first, lockstep)) if rome_clock::now_ms().is_some() == *lockstep => {
                    let mut store = lock(&self.store);
                    // A wait that would be queued needs its query held,
                    // which only the loop does; asked under the same lock
                    // as the wait is applied, so the answer holds.
                    if let Request::Wait(w) = &request {
                        if !store.wait_answers_at_once(&w.name, w.ticket.as_deref(), w.units) {
                            return false;
                        }
                    }
                    let mut applied = request.apply(&mut store, Instant::now());
                    // Queued under the store's lock, so changes made on
                    // two threads are followed up in their order; the
                    // queue is unbounded, so none is lost. A signal that
                    // granted nothing leaves nothing to do, and the task
                    // is not woken for it.
                    if let Ok(a) = applied.as_mut() {
                        if a.commit.is_some() || !a.grants.is_empty() {
                            let first_queued = self.follows.push(Follow {
                                commit: a.commit.take(),
                                grants: std::mem::take(&mut a.grants),
                            });
                            if first_queued {
                                wake = Some(first);
                            }
                        }
                    }
                    applied
                }
                _ => return false,
            },
            _ => return false,
        };
        let answered = match applied {
            Ok(crate::cmd::Applied {
                reply: Some(payload),
                ..
            }) => {
                rome_serve::reply_now(query, key, payload, Encoding::APPLICATION_JSON);
                true
            }
            // What is answered here always answers (a wait that would be
            // held was left to the loop above); were one not to, it is
            // done all the same and must not be done again.
            Ok(_) => true,
            // A request that failed changed nothing: the loop answers it
            // with its error.
            Err(_) => false,
        };
        if let Some(task) = wake {
            let _ = task.send(Event::Own(Own::Drain));
        }
        answered
    }
}

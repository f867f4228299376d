//! Lock-step across processes: the world's stepper and the processes that
//! follow its clock over the network (clients started with `--sim-time`).

use crate::world::{SimWorld, Stepper};
use rome_hardware::server::declare_err;
use rome_hardware::{locked, ServerError};
use rome_schema::Root;
use rome_serve::parties::Heard;
use std::collections::HashMap;
use std::sync::Arc;
use zenoh::Session;

/// The processes following a lock-step clock over the network (clients
/// started with `--sim-time`): each is a party of `clock`, sent every
/// instant and waited for until it acknowledges it.
///
/// An instant is settled in rounds ([`rome_schema::sim::Clock::round`]):
/// round 0 moves time on; then, while anyone (a party, or this process)
/// had something to do since the round before, the instant is sent again.
/// Each follower answers a round only once it has heard every other
/// party's answer to the round before, and Zenoh keeps one sender's
/// messages in order: whatever a party sent before its answer has reached
/// every follower by then. A round in which nobody worked so proves that
/// no message between followers is still on its way, and the world may
/// step.
#[derive(Clone)]
pub struct Parties {
    inner: Arc<std::sync::Mutex<PartyMap>>,
    _subscribers: Arc<(zenoh::pubsub::Subscriber<()>, zenoh::pubsub::Subscriber<()>)>,
}

#[derive(Default)]
struct PartyMap {
    parties: HashMap<String, Party>,
    /// The instant and round the parties were last sent.
    time_ms: u64,
    round: u32,
    /// Parties that left since the present round was sent: their last
    /// messages may still be on their way, so another round follows, in
    /// which each follower waits for them as for the others (until their
    /// token's removal, which comes after those messages).
    left: Vec<String>,
}

struct Party {
    clock: rome_clock::External,
    /// The instant and round this party is to answer (`None`: not sent one
    /// since it joined).
    expected: Option<(u64, u32)>,
    /// Whether its answer said it had worked since its answer before.
    worked: bool,
    /// Whether its answer said its servers hold requests for a release.
    holding: bool,
}

/// What follows a round every party has answered ([`Parties::close`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Close {
    /// Someone had something to do: the instant is sent again.
    Another,
    /// Nobody had, but requests wait for a release: every process hands
    /// them to its servers, this one first, then the instant is sent again
    /// with `release`.
    Release,
    /// Nothing is left: the world may step.
    Over,
}

impl Parties {
    /// Follows the parties' liveliness tokens and acknowledgements.
    pub async fn follow(
        session: &Session,
        root: &Root,
        clock: &rome_clock::LockStep,
    ) -> Result<Parties, ServerError> {
        let inner: Arc<std::sync::Mutex<PartyMap>> = Arc::default();
        let subscribers = {
            let (inner, clock) = (inner.clone(), clock.clone());
            rome_serve::parties::follow(session, root, move |heard| {
                let mut all = locked(&inner);
                match heard {
                    Heard::Joined(id) => {
                        tracing::info!(party = %id, "a process follows the lock-step clock");
                        let party = Party {
                            clock: clock.external(&format!("process {id}")),
                            expected: None,
                            worked: true,
                            holding: false,
                        };
                        all.parties.insert(id.to_string(), party);
                    }
                    Heard::Left(id) => {
                        tracing::info!(party = %id, "a process no longer follows the lock-step clock");
                        let was = all.parties.remove(id);
                        if was.is_some_and(|p| p.expected.is_some()) && all.left.len() < 4096 {
                            all.left.push(id.to_string());
                        }
                    }
                    Heard::Answered(id, ack) => {
                        tracing::trace!(party = %id, time_ms = ack.time_ms, round = ack.round, worked = ack.worked, "answer heard");
                        if let Some(party) = all.parties.get_mut(id) {
                            if party.expected == Some((ack.time_ms, ack.round)) {
                                party.worked = ack.worked;
                                party.holding = ack.holding;
                                party.clock.done();
                            }
                        }
                    }
                }
            })
            .await
            .map_err(|e| declare_err("the clock parties' subscribers", e))?
        };
        Ok(Parties {
            inner,
            _subscribers: Arc::new(subscribers),
        })
    }

    /// Every party is sent instant `time_ms` (its round 0): the clock waits
    /// for each. Returns the message that says so.
    pub fn expect(&self, time_ms: u64) -> rome_schema::sim::Clock {
        let mut all = locked(&self.inner);
        all.time_ms = time_ms;
        all.round = 0;
        all.left.clear();
        for party in all.parties.values_mut() {
            party.expected = Some((time_ms, 0));
            party.clock.expect();
        }
        rome_schema::sim::Clock::instant(time_ms, true)
    }

    /// Once every party has answered the present round: what follows it,
    /// given whether this process had anything to do during the round
    /// (`here_worked`) and holds requests for a release (`here_holding`).
    /// With no party, only a release of this process's own requests.
    pub fn close(&self, here_worked: bool, here_holding: bool) -> Close {
        let all = locked(&self.inner);
        if all.parties.is_empty() {
            return if here_holding {
                Close::Release
            } else {
                Close::Over
            };
        }
        let anyone_worked = all.round == 0
            || here_worked
            || !all.left.is_empty()
            || all
                .parties
                .values()
                .any(|p| p.worked || p.expected.is_none());
        if anyone_worked {
            Close::Another
        } else if here_holding || all.parties.values().any(|p| p.holding) {
            Close::Release
        } else {
            Close::Over
        }
    }

    /// Sends every party the next round of the instant (with `release`, see
    /// [`Close::Release`]) and returns it; `None` when there is no party.
    pub fn next_round(&self, release: bool) -> Option<rome_schema::sim::Clock> {
        let mut all = locked(&self.inner);
        if all.parties.is_empty() {
            return None;
        }
        all.round += 1;
        let (time_ms, round) = (all.time_ms, all.round);
        let mut ids = Vec::with_capacity(all.parties.len());
        for (id, party) in all.parties.iter_mut() {
            if party.expected.is_some() {
                // Only those that answered the round before: a newcomer has
                // sent no answer to wait for.
                ids.push(id.clone());
            }
            party.expected = Some((time_ms, round));
            party.worked = true;
            party.holding = false;
            party.clock.expect();
        }
        ids.append(&mut all.left);
        ids.sort();
        Some(rome_schema::sim::Clock {
            time_ms,
            lockstep: true,
            round,
            parties: ids,
            release,
        })
    }

    /// How many processes follow the clock.
    pub fn len(&self) -> usize {
        locked(&self.inner).parties.len()
    }

    /// Whether none does.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// Publishes `clock` on `key` (`<root>/sim/clock`). A lock-step clock is
/// never dropped on the way (its followers need every instant); a paced
/// one may be, as any stream.
pub async fn publish_clock(
    session: &Session,
    key: &str,
    clock: &rome_schema::sim::Clock,
) -> zenoh::Result<()> {
    session
        .put(key, rome_schema::encode(clock))
        .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
        .congestion_control(if clock.lockstep {
            zenoh::qos::CongestionControl::Block
        } else {
            zenoh::qos::CongestionControl::Drop
        })
        .await
}

/// Steps `world` in lock-step with `clock` and with `parties`, the
/// processes that follow it over the network: each instant and each of
/// its rounds is published on `<root>/sim/clock`, and the world steps once
/// a round finds that nobody, here or there, had anything left to do.
/// Every instant and round is published by the stepper itself, at the
/// point of its decision. Returns the stepper.
pub fn start_lockstep_with(
    session: &Session,
    root: &Root,
    world: &SimWorld,
    clock: &rome_clock::LockStep,
    parties: Parties,
) -> Stepper {
    // Requests from the parties are held until their round is over, then
    // taken in stamp order (`LockStep::hand_over`, called by the stepper).
    clock.split_into_rounds("rome sim");
    let on_step = {
        let (parties, session, key) = (parties.clone(), session.clone(), root.sim_clock());
        let clock = clock.clone();
        move |t| {
            clock.set_round(t, 0);
            // Busy before the instant is announced: no reply can come
            // before the clock knows to wait for it. Sent here and now,
            // before this process's servers wake to the instant: every
            // follower hears the new time before what they publish at it,
            // so it reacts to a reading at the reading's instant.
            let clock = parties.expect(t);
            let sent = zenoh::Wait::wait(
                session
                    .put(&key, rome_schema::encode(&clock))
                    .encoding(zenoh::bytes::Encoding::APPLICATION_JSON)
                    .congestion_control(zenoh::qos::CongestionControl::Block),
            );
            match sent {
                // The program is ending: nobody is waiting on the clock.
                Err(_) if session.is_closed() => {}
                Err(e) => tracing::warn!(%key, error = %e, "clock not published"),
                Ok(()) => {}
            }
        }
    };
    // Whether this process worked during a round: its participants'
    // activity since the round was sent.
    let (here, mut seen) = (clock.clone(), clock.activity());
    let (session, key) = (session.clone(), root.sim_clock());
    let another_round = move || {
        let now = here.activity();
        let worked = now != seen;
        seen = now;
        let close = parties.close(worked, here.holding());
        let (parties, here, session, key) =
            (parties.clone(), here.clone(), session.clone(), key.clone());
        async move {
            let release = match close {
                Close::Over => return false,
                Close::Another => false,
                Close::Release => {
                    let (t, r) = here.round();
                    here.hand_over((t, r.saturating_add(1)), true).await;
                    // This process's servers finish with what they were
                    // handed (their replies sent) before the round that
                    // marks its end is.
                    here.settled().await;
                    true
                }
            };
            match parties.next_round(release) {
                Some(round) => {
                    here.set_round(round.time_ms, round.round);
                    match publish_clock(&session, &key, &round).await {
                        // The program is ending: nobody is waiting on it.
                        Err(_) if session.is_closed() => {}
                        Err(e) => tracing::warn!(%key, error = %e, "clock not published"),
                        Ok(()) => {}
                    }
                    true
                }
                // Alone: another look once what was handed over is done.
                None => release,
            }
        }
    };
    world.start_lockstep_rounds(clock.clone(), None, on_step, another_round)
}

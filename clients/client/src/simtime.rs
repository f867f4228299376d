//! Following the simulator's clock from another process: ROS's
//! `use_sim_time`.
//!
//! [`follow`] runs a future on a local [`rome_clock::LockStep`] that moves
//! only when `<root>/sim/clock` says so, so every sleep, period and
//! timeout in it is simulated time. When the simulator runs in lock-step
//! (`rome sim --lockstep`) the process also declares itself a party
//! (`<root>/sim/clock/party/<id>`) and, after each instant, acknowledges
//! it on `<root>/sim/clock/ack/<id>` once everything it runs has finished
//! with it: the world waits for it as for a client in its own process.
//!
//! Messages from the simulator's process (robot streams, replies) arrive
//! before the next instant's clock, since Zenoh keeps one sender's
//! messages in order on a link: a reaction to a reading of instant `t`
//! happens at `t` in every run.
//!
//! Messages between two followers (a commit or a grant the data server
//! publishes) are brought to the same rule by rounds: the simulator sends
//! an instant again ([`Clock::round`]) while anyone had something to do
//! since the round before, and a follower answers round `r` only once it
//! has heard every other party's answer to round `r − 1`. What a party
//! sent before answering has reached this process before its answer did,
//! so a round in which nobody worked shows that nothing is on its way.
//! One sender's messages keep their order only within one of Zenoh's
//! priority bands (a reply sent before a round was seen to arrive after
//! it across two), so in a lock-step run every request, reply, answer and
//! round travels in the default band: the clients' priorities still ride
//! as a parameter, which is what the servers go by.
//!
//! Requests to a server from two processes within one round are put in
//! the same order in every run: each carries a stamp (`rome_clock::Stamp`:
//! its round, this process's name, a count), and a server holds what
//! changes something until its round is over, then takes it in stamp
//! order (`rome_clock::Hold`); see `LockStep::hand_over`.

use crate::ClientError;
use rome_schema::sim::{Clock, ClockAck};
use rome_schema::{decode, encode, Root};
use rome_serve::parties::Heard::{Answered, Joined, Left};
use std::collections::{HashMap, HashSet};
use std::future::Future;
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;
use zenoh::Session;

/// How long to wait for the first clock before saying so (then waiting on).
const SAY_AFTER: Duration = Duration::from_secs(2);

/// Runs `fut`, named `name`, in the simulator's time; see the module.
/// Returns once `fut` does. Waits for the simulator's first clock message
/// before starting `fut`. `name` also orders this process's requests
/// among those of the same round from other processes: the same in every
/// run, and unlike any other party's.
pub async fn follow<F: Future>(
    session: &Session,
    root: &Root,
    name: &str,
    fut: F,
) -> Result<F::Output, ClientError> {
    let key = root.sim_clock();
    // Decoded as they arrive, on the link's own thread, so that a new time
    // is announced to the clock before any message behind it is handed
    // over (`LockStep::announce`).
    let following: std::sync::Arc<std::sync::OnceLock<rome_clock::LockStep>> = Default::default();
    // A new time is announced only while this process is a party and its
    // driver (below) waits for the next clock message: a party's world
    // moves on only after the party has answered, so the announcement
    // cannot keep from its turn a participant the driver is waiting for
    // (as it would, were the time announced in the middle of a round).
    let party = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let waiting = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
    let (tx, ticks) = flume::unbounded::<Clock>();
    let _ticks = {
        let (following, said) = (following.clone(), key.clone());
        let (party, waiting) = (party.clone(), waiting.clone());
        session
            .declare_subscriber(&key)
            .callback(move |sample| {
                let tick: Clock = match decode(&sample.payload().to_bytes(), "sim clock") {
                    Ok(c) => c,
                    Err(e) => {
                        tracing::warn!(key = %said, error = %e, "clock message skipped");
                        return;
                    }
                };
                if let Some(clock) = following.get() {
                    if tick.lockstep
                        && party.load(std::sync::atomic::Ordering::Acquire)
                        && waiting.load(std::sync::atomic::Ordering::Acquire)
                        && tick.time_ms > clock.now_ms()
                    {
                        clock.announce();
                    }
                }
                let _ = tx.send(tick);
            })
            .await
            .map_err(ClientError::zenoh)?
    };
    let first = match tokio::time::timeout(SAY_AFTER, ticks.recv_async()).await {
        Ok(c) => c,
        Err(_) => {
            tracing::warn!(%key, "waiting for the simulator's clock (is `rome sim` running?)");
            ticks.recv_async().await
        }
    }
    .map_err(|_| ClientError::Zenoh("the clock subscription ended".into()))?;
    let clock = rome_clock::LockStep::new(first.time_ms);
    let _ = following.set(clock.clone());
    let id = session.zid().to_string();
    let ack_key = root.sim_clock_ack(&id);
    let heard = Heard::follow(session, root, &id).await?;
    let driver = {
        let (clock, session, waiting) = (clock.clone(), session.clone(), waiting.clone());
        tokio::spawn(async move {
            // The participants' activity when this process last answered.
            let mut seen = clock.activity();
            loop {
                waiting.store(true, std::sync::atomic::Ordering::Release);
                let Ok(tick) = ticks.recv_async().await else {
                    break;
                };
                waiting.store(false, std::sync::atomic::Ordering::Release);
                // What is sent from here on precedes this round's answer.
                clock.set_round(tick.time_ms, tick.round);
                // Every clock message, even a round that does not move
                // time: each ends what its callback may have announced.
                tracing::trace!(time_ms = tick.time_ms, round = tick.round, "clock heard");
                // `advance` waits for the turn; given up at a yield, before
                // it has taken it, so it is tried again as if new.
                saying_when_stuck(
                    &clock,
                    &tick,
                    || clock.advance(tick.time_ms),
                    "lock-step: the clock cannot move on in this process",
                )
                .await;
                if !tick.lockstep {
                    continue;
                }
                if tick.round > 0 {
                    // Everything the other parties sent before answering
                    // the round before is here once their answers are.
                    heard
                        .answers(&tick.parties, (tick.time_ms, tick.round - 1))
                        .await;
                }
                if clock.in_rounds() {
                    // Every request stamped before this round is here: the
                    // reads stamped up to it are answered now and, after a
                    // round in which nobody had anything to do (`release`),
                    // first the requests that change something, in stamp
                    // order.
                    clock
                        .hand_over((tick.time_ms, tick.round), tick.release)
                        .await;
                }
                // A process that never settles holds every other up.
                saying_when_stuck(
                    &clock,
                    &tick,
                    || clock.settled(),
                    "lock-step: this process has not finished with the instant",
                )
                .await;
                // Set before the look at the activity: a participant woken
                // after the look stamps what it sends for the next round,
                // and one woken before it is counted in this answer.
                clock.set_round(tick.time_ms, tick.round.saturating_add(1));
                let now = clock.activity();
                let ack = ClockAck {
                    time_ms: tick.time_ms,
                    round: tick.round,
                    worked: tick.round == 0 || now != seen,
                    holding: clock.holding(),
                };
                seen = now;
                tracing::trace!(
                    time_ms = ack.time_ms,
                    round = ack.round,
                    worked = ack.worked,
                    holding = ack.holding,
                    "answering"
                );
                // From here on the driver waits on nothing but the next
                // clock message, which may come before the answer's `put`
                // has returned.
                waiting.store(true, std::sync::atomic::Ordering::Release);
                // In the default band, as every request of a lock-step
                // run: Zenoh keeps one sender's messages in order only
                // within a band.
                let sent = session
                    .put(&ack_key, encode(&ack))
                    .encoding(Encoding::APPLICATION_JSON)
                    .congestion_control(CongestionControl::Block)
                    .await;
                match sent {
                    // The program is ending: nothing is waiting on it.
                    Err(_) if session.is_closed() => break,
                    Err(e) => {
                        tracing::warn!(key = %ack_key, error = %e, "clock acknowledgement not sent")
                    }
                    Ok(()) => {}
                }
            }
        })
    };
    // What this process runs starts at the instant it first heard, and has
    // settled there, before the process declares itself a party: a world
    // held for its parties (`--parties`) cannot step before that, so the
    // process starts at the same instant in every run.
    let run = clock.participate(name, fut);
    tokio::pin!(run);
    let mut token = None;
    if first.lockstep {
        let declared = async {
            clock.settled().await;
            // From now on requests between processes go by rounds.
            clock.split_into_rounds(name);
            party.store(true, std::sync::atomic::Ordering::Release);
            session
                .liveliness()
                .declare_token(root.sim_clock_party(&id))
                .await
        };
        tokio::select! {
            biased;
            out = &mut run => {
                driver.abort();
                return Ok(out);
            }
            t = declared => token = Some(t.map_err(ClientError::zenoh)?),
        }
    }
    let out = run.await;
    driver.abort();
    drop(token);
    Ok(out)
}

/// Runs `step` (made anew after each [`STUCK_SAY_EVERY`], so it must be
/// safe to drop at an await) until it completes, saying `what` with the
/// clock's state each time it has not: who in this process keeps the
/// world waiting.
async fn saying_when_stuck<F: Future<Output = ()>>(
    clock: &rome_clock::LockStep,
    tick: &Clock,
    mut step: impl FnMut() -> F,
    what: &str,
) {
    while tokio::time::timeout(STUCK_SAY_EVERY, step()).await.is_err() {
        tracing::warn!(
            time_ms = tick.time_ms,
            round = tick.round,
            clock = %clock.describe(),
            "{what}"
        );
    }
}

/// How often to say that this process has not settled at an instant.
const STUCK_SAY_EVERY: Duration = Duration::from_secs(10);
/// How long to wait for another party's answer before saying so.
const ANSWER_SAY_AFTER: Duration = Duration::from_secs(5);
/// How long to wait for it at all: a party that vanished without its
/// liveliness token going (a killed host) must not stop the world.
const ANSWER_GIVE_UP: Duration = Duration::from_secs(30);

/// How many parties' answers are kept at most.
const MAX_PARTIES: usize = 4096;

/// The latest answer heard from every other party, and which have gone.
struct Heard {
    me: String,
    state: std::sync::Arc<std::sync::Mutex<HeardState>>,
    changed: std::sync::Arc<tokio::sync::Notify>,
    _subscribers: (zenoh::pubsub::Subscriber<()>, zenoh::pubsub::Subscriber<()>),
}

#[derive(Default)]
struct HeardState {
    /// Party id → the latest (instant, round) it answered.
    answered: HashMap<String, (u64, u32)>,
    /// Parties whose liveliness token has gone.
    gone: HashSet<String>,
}

impl Heard {
    async fn follow(session: &Session, root: &Root, me: &str) -> Result<Heard, ClientError> {
        let state: std::sync::Arc<std::sync::Mutex<HeardState>> = Default::default();
        let changed = std::sync::Arc::new(tokio::sync::Notify::new());
        let subscribers = {
            let (state, changed, me) = (state.clone(), changed.clone(), me.to_string());
            rome_serve::parties::follow(session, root, move |heard| {
                let mut st = lock(&state);
                match heard {
                    Answered(id, _) if id == me => return,
                    Answered(id, ack) => {
                        let at = (ack.time_ms, ack.round);
                        if !st.answered.contains_key(id) && st.answered.len() >= MAX_PARTIES {
                            // Anyone can publish on the key: a flood of
                            // made-up ids must not grow this without end.
                            return;
                        }
                        let latest = st.answered.entry(id.to_string()).or_insert(at);
                        *latest = (*latest).max(at);
                    }
                    Joined(id) => {
                        st.gone.remove(id);
                    }
                    Left(id) => {
                        st.answered.remove(id);
                        if st.gone.len() < MAX_PARTIES {
                            st.gone.insert(id.to_string());
                        }
                    }
                }
                drop(st);
                changed.notify_waiters();
            })
            .await
            .map_err(ClientError::zenoh)?
        };
        Ok(Heard {
            me: me.to_string(),
            state,
            changed,
            _subscribers: subscribers,
        })
    }

    /// Waits until every party of `parties` (this one aside) has answered
    /// round `at` or a later one, or has gone.
    async fn answers(&self, parties: &[String], at: (u64, u32)) {
        let started = std::time::Instant::now();
        let mut said = false;
        loop {
            let notified = self.changed.notified();
            tokio::pin!(notified);
            notified.as_mut().enable();
            let missing: Vec<String> = {
                let st = lock(&self.state);
                parties
                    .iter()
                    .filter(|p| {
                        p.as_str() != self.me
                            && !st.gone.contains(*p)
                            && st.answered.get(*p).is_none_or(|a| *a < at)
                    })
                    .cloned()
                    .collect()
            };
            if missing.is_empty() {
                return;
            }
            let waited = started.elapsed();
            if waited >= ANSWER_GIVE_UP {
                tracing::warn!(
                    ?missing,
                    instant = at.0,
                    round = at.1,
                    "lock-step clock: answering without these parties' answers to the round before"
                );
                return;
            }
            if waited >= ANSWER_SAY_AFTER && !said {
                said = true;
                tracing::warn!(
                    ?missing,
                    instant = at.0,
                    round = at.1,
                    "lock-step clock: waiting for these parties' answers to the round before"
                );
            }
            let _ = tokio::time::timeout(Duration::from_millis(500), notified).await;
        }
    }
}

fn lock<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

//! The processes that follow a lock-step clock (its parties), as heard on
//! Zenoh: their liveliness tokens under `<root>/sim/clock/party/<id>` and
//! their answers to each instant. The clock's driver follows them to know
//! when a round is over; every party follows the others to know whom it
//! still waits for. Both hear them through [`follow`].

use rome_schema::sim::ClockAck;
use rome_schema::Root;
use std::sync::Arc;
use zenoh::pubsub::Subscriber;
use zenoh::sample::SampleKind;
use zenoh::Session;

/// One thing heard of a party, by its id (the last chunk of its key).
#[derive(Debug, Clone, PartialEq)]
pub enum Heard<'a> {
    /// Its liveliness token appeared (or was there already).
    Joined(&'a str),
    /// Its liveliness token went: the process ended or was cut off.
    Left(&'a str),
    /// It answered an instant.
    Answered(&'a str, ClockAck),
}

/// Follows the clock's parties under `root`, handing `on` each thing
/// heard: the tokens already there, then every change and answer.
/// An answer that does not decode is logged and skipped (anyone may
/// publish on the key). Dropping the subscribers stops it.
pub async fn follow(
    session: &Session,
    root: &Root,
    on: impl Fn(Heard<'_>) + Send + Sync + 'static,
) -> zenoh::Result<(Subscriber<()>, Subscriber<()>)> {
    let on = Arc::new(on);
    // Answers first: once the tokens are heard, no answer is missed.
    let answers = {
        let on = on.clone();
        session
            .declare_subscriber(root.sim_clock_acks())
            .callback(move |s| {
                let key = s.key_expr().as_str();
                match rome_schema::decode(&s.payload().to_bytes(), "clock ack") {
                    Ok(ack) => on(Heard::Answered(last_chunk(key), ack)),
                    Err(e) => tracing::warn!(%key, error = %e, "clock acknowledgement skipped"),
                }
            })
            .await?
    };
    let members = session
        .liveliness()
        .declare_subscriber(root.sim_clock_parties())
        .history(true)
        .callback(move |s| {
            let id = last_chunk(s.key_expr().as_str());
            match s.kind() {
                SampleKind::Put => on(Heard::Joined(id)),
                SampleKind::Delete => on(Heard::Left(id)),
            }
        })
        .await?;
    Ok((answers, members))
}

fn last_chunk(key: &str) -> &str {
    key.rsplit('/').next().unwrap_or(key)
}

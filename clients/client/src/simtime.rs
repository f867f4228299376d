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

use crate::ClientError;
use rome_schema::sim::{Clock, ClockAck};
use rome_schema::{decode, encode, Root};
use std::future::Future;
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::qos::CongestionControl;
use zenoh::Session;

/// How long to wait for the first clock before saying so (then waiting on).
const SAY_AFTER: Duration = Duration::from_secs(2);

/// Runs `fut`, named `name`, in the simulator's time; see the module.
/// Returns once `fut` does. Waits for the simulator's first clock message
/// before starting `fut`.
pub async fn follow<F: Future>(
    session: &Session,
    root: &Root,
    name: &str,
    fut: F,
) -> Result<F::Output, ClientError> {
    let key = root.sim_clock();
    let ticks = session
        .declare_subscriber(&key)
        .await
        .map_err(ClientError::zenoh)?;
    let first = loop {
        let sample = match tokio::time::timeout(SAY_AFTER, ticks.recv_async()).await {
            Ok(s) => s.map_err(ClientError::zenoh)?,
            Err(_) => {
                tracing::warn!(%key, "waiting for the simulator's clock (is `rome sim` running?)");
                ticks.recv_async().await.map_err(ClientError::zenoh)?
            }
        };
        match decode::<Clock>(&sample.payload().to_bytes(), "sim clock") {
            Ok(c) => break c,
            Err(e) => tracing::warn!(%key, error = %e, "clock message skipped"),
        }
    };
    let clock = rome_clock::LockStep::new(first.time_ms);
    let id = session.zid().to_string();
    let token = if first.lockstep {
        Some(
            session
                .liveliness()
                .declare_token(root.sim_clock_party(&id))
                .await
                .map_err(ClientError::zenoh)?,
        )
    } else {
        None
    };
    let ack_key = root.sim_clock_ack(&id);
    let driver = {
        let (clock, session) = (clock.clone(), session.clone());
        tokio::spawn(async move {
            while let Ok(sample) = ticks.recv_async().await {
                let tick: Clock = match decode(&sample.payload().to_bytes(), "sim clock") {
                    Ok(c) => c,
                    Err(e) => {
                        tracing::warn!(error = %e, "clock message skipped");
                        continue;
                    }
                };
                clock.advance(tick.time_ms).await;
                if tick.lockstep {
                    clock.settled().await;
                    let ack = ClockAck {
                        time_ms: tick.time_ms,
                    };
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
            }
        })
    };
    let out = clock.participate(name, fut).await;
    driver.abort();
    drop(token);
    Ok(out)
}

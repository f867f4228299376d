//! The data-server load of the soak: writers that remember what was
//! acknowledged, and waiters that hold a semaphore's units and record when.

use super::*;
use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions};
use rome_sim::rng::Rng;
use std::sync::atomic::Ordering;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

pub(super) async fn data_client(port: u16, role: &str) -> anyhow::Result<DataClient> {
    let session = NetOptions::loopback_client(port).open().await?;
    let options = DataOptions {
        connect_timeout: Duration::from_secs(30),
        request_timeout: Duration::from_secs(15),
        ..DataOptions::new(role)
    };
    Ok(DataClient::connect(&session, options).await?)
}

/// Writes 1, 2, 3 … to `soak/w<i>`, each after the last was answered.
pub(super) async fn writer(i: usize, port: u16, shared: Arc<Shared>) {
    let name = format!("soak/w{i}");
    let Ok(ds) = data_client(port, "soak-writer").await else {
        return;
    };
    while !shared.stop.load(Ordering::SeqCst) {
        let seq = shared.attempted.lock().map_or(0, |a| a[i]) + 1;
        if let Ok(mut a) = shared.attempted.lock() {
            a[i] = seq;
        }
        match ds.set(&name, &seq).await {
            Ok(_) => {
                if let Ok(mut a) = shared.acked.lock() {
                    a[i] = seq;
                }
            }
            Err(_) => {
                shared.write_errors.fetch_add(1, Ordering::Relaxed);
            }
        }
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// One unit held by a waiter, from grant to give-back.
#[derive(Debug, Clone, Copy)]
pub(super) struct Hold {
    pub(super) start: Instant,
    pub(super) end: Instant,
    pub(super) revoked: bool,
}

/// The most holds (not revoked) overlapping at any moment.
pub(super) fn deepest_overlap(holds: &[Hold]) -> i64 {
    let mut events: Vec<(Instant, i64)> = holds
        .iter()
        .filter(|h| !h.revoked)
        .flat_map(|h| [(h.start, 1), (h.end, -1)])
        .collect();
    // Ends before starts at the same instant: a unit handed straight on.
    events.sort_by(|a, b| a.0.cmp(&b.0).then(a.1.cmp(&b.1)));
    let (mut now, mut most) = (0, 0);
    for (_, d) in events {
        now += d;
        most = most.max(now);
    }
    most
}

/// A waiter task and what it holds.
pub(super) struct Waiter {
    pub(super) task: tokio::task::JoinHandle<()>,
    pub(super) session: Arc<Mutex<Option<zenoh::Session>>>,
}

impl Waiter {
    pub(super) fn start(
        i: usize,
        port: u16,
        pool: &'static str,
        shared: Arc<Shared>,
        rng: &mut Rng,
    ) -> Waiter {
        let session = Arc::new(Mutex::new(None));
        let (s, sh) = (session.clone(), shared.clone());
        let seed = rng.next_u64() ^ i as u64;
        let task = tokio::spawn(async move {
            let mut rng = Rng::new(seed);
            let Ok(zs) = NetOptions::loopback_client(port).open().await else {
                return;
            };
            if let Ok(mut slot) = s.lock() {
                *slot = Some(zs.clone());
            }
            let options = DataOptions {
                connect_timeout: Duration::from_secs(30),
                ..DataOptions::new("soak-waiter")
            };
            let Ok(ds) = DataClient::connect(&zs, options).await else {
                return;
            };
            while !sh.stop.load(Ordering::SeqCst) {
                if ds.wait_undo(pool).await.is_err() {
                    tokio::time::sleep(Duration::from_millis(300)).await;
                    continue;
                }
                let start = Instant::now();
                sh.granted.fetch_add(1, Ordering::Relaxed);
                tokio::time::sleep(Duration::from_millis(50 + rng.next_u64() % 250)).await;
                // The server takes an undo unit back when its owner seems
                // gone (a link cut closes the session); the give-back then
                // says so (conflict), and the hold did not count. Only the
                // holds the server stood behind must never overlap more
                // than `units` deep.
                let end = Instant::now();
                let revoked = matches!(
                    ds.give_back(pool).await,
                    Err(e) if e.code() == Some(rome_schema::ErrorCode::Conflict)
                );
                if let Ok(mut holds) = sh.holds.lock() {
                    holds.push(Hold {
                        start,
                        end,
                        revoked,
                    });
                }
            }
        });
        Waiter { task, session }
    }

    /// The client dies: its task stops and its session closes, so the
    /// server sees the owner go.
    pub(super) async fn crash(&mut self) {
        self.task.abort();
        let s = self.session.lock().ok().and_then(|mut s| s.take());
        if let Some(s) = s {
            let _ = s.close().await;
        }
    }

    /// Lets the waiter finish its hold, give the unit back and go.
    pub(super) async fn finish(&mut self) {
        let _ = tokio::time::timeout(Duration::from_secs(20), &mut self.task).await;
        self.crash().await;
    }
}

//! The hardware servers over real Zenoh sessions on loopback: locks,
//! priorities, the lock's storage, virtual coordinates, cameras, bad input,
//! and a holder in another process killed with SIGKILL.

#![allow(clippy::unwrap_used)]

use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::{ClientError, RobotClient, RobotOptions};
use rome_hardware::base::Base;
use rome_hardware::device::{BaseDevice, BaseOp, BaseStatus, DeviceError};
use rome_hardware::robot::{self, Rates, Running};
use rome_hardware::ServerConfig;
use rome_schema::robot::lock::{LockInfo, LockRecord};
use rome_schema::robot::{BaseState, Device};
use rome_schema::{ErrorCode, Root};
use rome_sim_hardware::robot::spawn_sim_robot;
use rome_sim_hardware::world::Stepper;
use rome_tests::{eventually, peer};
use std::collections::VecDeque;
use std::io::BufRead;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};
use zenoh::{Session, Wait};

/// A base that records every command and plays back scripted x registers.
#[derive(Clone, Default)]
struct Recorder {
    ops: Arc<Mutex<Vec<BaseOp>>>,
    xs: Arc<Mutex<VecDeque<i16>>>,
    x: Arc<Mutex<i16>>,
}

impl BaseDevice for Recorder {
    async fn command(&mut self, op: BaseOp) -> Result<BaseStatus, DeviceError> {
        if op != BaseOp::Status {
            self.ops.lock().unwrap().push(op);
        }
        if let Some(x) = self.xs.lock().unwrap().pop_front() {
            *self.x.lock().unwrap() = x;
        }
        Ok(BaseStatus {
            raw_x: *self.x.lock().unwrap(),
            raw_y: 0,
            state: BaseState {
                mode: "joystick".into(),
                ..BaseState::default()
            },
        })
    }
}

/// Servers on their own loopback port, reached by client sessions.
struct Harness {
    port: u16,
    state: Option<Duration>,
    session: Session,
    servers: Vec<Running>,
    _stepper: Option<Stepper>,
}

impl Harness {
    /// A peer session on a loopback port of its own, and that port.
    async fn session() -> (Session, u16) {
        open_loopback_peer(&[]).await.unwrap()
    }

    /// A session on a port of its own and no servers yet; servers started
    /// on it publish their state every `state`.
    async fn empty(state: Option<Duration>) -> Harness {
        let (session, port) = Self::session().await;
        Harness {
            port,
            state,
            session,
            servers: Vec::new(),
            _stepper: None,
        }
    }

    /// A recording base for robot `r1`, with a storage in another session.
    async fn recorder(rec: &Recorder, storage: bool) -> Harness {
        let mut rig = Self::empty(Some(Duration::from_millis(20))).await;
        if storage {
            let s = rig.peer_session().await;
            tokio::spawn(async move {
                let root = Root::default();
                rome_hardware::storage::run(
                    s,
                    &root,
                    root.store_all(),
                    std::future::pending::<()>(),
                )
                .await
            });
        }
        rig.start_base(rec).await;
        rig
    }

    async fn start_base(&mut self, rec: &Recorder) {
        let config = ServerConfig::new(&Root::default(), "r1", Device::Base).unwrap();
        self.servers.push(robot::spawn(
            &self.session,
            config,
            Base::new("r1", rec.clone(), self.state),
        ));
        self.await_alive("base").await;
    }

    /// Robot r1 on the Figure 5.3 map, all its servers, world at real time.
    async fn sim(camera: Duration) -> Harness {
        let (session, port) = Self::session().await;
        let world = rome_tests::world("fig5_3", rome_tests::quiet(), &[("r1", "301L")]);
        let stepper = world.start(Some(1.0));
        let rates = Rates {
            state: Some(Duration::from_millis(50)),
            scan: Some(Duration::from_millis(20)),
            camera,
        };
        let servers = spawn_sim_robot(&session, &Root::default(), &world, "r1", rates).unwrap();
        let rig = Harness {
            port,
            state: rates.state,
            session,
            servers,
            _stepper: Some(stepper),
        };
        for d in ["base", "proximity", "camera/up", "camera/side"] {
            rig.await_alive(d).await;
        }
        rig
    }

    async fn await_alive(&self, device: &str) {
        let key = format!("rome/alive/server/robot/r1/{device}");
        rome_tests::await_alive(&self.session, &key, 1).await
    }

    async fn peer_session(&self) -> Session {
        NetOptions::loopback(None, &[self.port])
            .open()
            .await
            .unwrap()
    }

    async fn client(&self, role: &str, priority: u8) -> RobotClient {
        let session = NetOptions::loopback_client(self.port).open().await.unwrap();
        let mut o = RobotOptions::new(role);
        o.priority = priority;
        RobotClient::connect(&session, "r1", o).await.unwrap()
    }

    /// Queue length as the base's state stream reports it.
    async fn queued(&self) -> usize {
        let c = self.client("watch", 128).await;
        let s = c.state().await.unwrap();
        s.next().await.unwrap().unwrap().queued
    }
}

fn velocities(rec: &Recorder) -> Vec<f64> {
    rec.ops
        .lock()
        .unwrap()
        .iter()
        .filter_map(|op| match op {
            BaseOp::Go(v) => Some(*v),
            _ => None,
        })
        .collect()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_held_lock_postpones_others_who_are_then_served_by_priority() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let holder = rig.client("holder", 128).await;
    let lock = holder.lock().await.unwrap();

    // Four clients queue behind the lock, low and high priorities mixed.
    let mut waiting = Vec::new();
    for (k, prio) in [(1.0, 10u8), (2.0, 200), (3.0, 10), (4.0, 200), (5.0, 128)] {
        let c = rig.client("contender", prio).await;
        waiting.push(tokio::spawn(async move { c.go(k).await }));
        // Arrival order must be known for the FIFO part of the check.
        let n = waiting.len();
        eventually(Duration::from_secs(5), "request queued", || async {
            rig.queued().await == n
        })
        .await;
    }
    // The holder goes straight through; nobody else has been served.
    holder.go(99.0).await.unwrap();
    assert_eq!(velocities(&rec), [99.0]);

    lock.unlock().await.unwrap();
    for w in waiting {
        w.await.unwrap().unwrap();
    }
    assert_eq!(velocities(&rec), [99.0, 2.0, 4.0, 5.0, 1.0, 3.0]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn stale_fences_are_refused_and_queued_requests_time_out_with_a_reason() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let a = rig.client("a", 128).await;
    let lock = a.lock().await.unwrap();
    let fence = lock.fence();
    lock.unlock().await.unwrap();

    // A plain query with the old fence: refused, naming the fence.
    let s = rig.peer_session().await;
    let err = plain_err(
        &s,
        &format!("rome/robot/r1/base/go?fence={fence}"),
        r#"{"velocity_mm_s":1}"#,
    )
    .await;
    assert_eq!(err["code"], "stale_fence");
    assert!(err["message"]
        .as_str()
        .unwrap()
        .contains(&fence.to_string()));

    // A waiting request gives up after its wait_ms, saying behind whom.
    let lock = a.lock().await.unwrap();
    let err = plain_err(&s, "rome/robot/r1/base/mode?wait_ms=200", "").await;
    assert_eq!(err["code"], "timed_out");
    assert!(
        err["message"].as_str().unwrap().contains(a.owner()),
        "{err}"
    );
    // A new grant's fence is above the old one.
    assert!(lock.fence() > fence);
    assert!(velocities(&rec).is_empty(), "nothing reached the device");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_suppressing_command_keeps_lower_priorities_off_until_it_lapses() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let s = rig.peer_session().await;
    let go = |v: f64| format!("{{\"velocity_mm_s\":{v}}}");
    // The dominant module: priority 200, suppressing for 60 s.
    plain(
        &s,
        "rome/robot/r1/base/go?priority=200;suppress_ms=60000;client=escape",
        &go(1.0),
    )
    .await
    .unwrap();
    // A lower priority's command that acts is refused, naming who and why.
    let err = plain_err(&s, "rome/robot/r1/base/go?priority=100", &go(2.0)).await;
    assert_eq!(err["code"], "suppressed", "{err}");
    let msg = err["message"].as_str().unwrap();
    assert!(
        msg.contains("priority 200") && msg.contains("'escape'") && msg.contains("'go'"),
        "{msg}"
    );
    // Reads pass, as do the same and higher priorities.
    plain(&s, "rome/robot/r1/base/pose?priority=100", "")
        .await
        .unwrap();
    plain(&s, "rome/robot/r1/base/go?priority=200", &go(3.0))
        .await
        .unwrap();
    plain(&s, "rome/robot/r1/base/go?priority=250", &go(4.0))
        .await
        .unwrap();
    // The lock holder's commands pass whatever its priority.
    let low = rig.client("holder", 10).await;
    let lock = low.lock().await.unwrap();
    low.go(5.0).await.unwrap();
    lock.unlock().await.unwrap();
    let stats = plain(&s, "rome/robot/r1/base/stats", "").await.unwrap();
    assert_eq!(stats["suppressed"], 1, "{stats}");
    assert_eq!(velocities(&rec), [1.0, 3.0, 4.0, 5.0]);
    // The same priority's next command renews the claim, here to 1.5 s;
    // once that lapses, the lower priority gets through again.
    plain(
        &s,
        "rome/robot/r1/base/go?priority=200;suppress_ms=1500",
        &go(6.0),
    )
    .await
    .unwrap();
    let err = plain_err(&s, "rome/robot/r1/base/go?priority=100", &go(7.0)).await;
    assert_eq!(err["code"], "suppressed");
    eventually(Duration::from_secs(5), "the claim lapses", || async {
        plain(&s, "rome/robot/r1/base/go?priority=100", &go(8.0))
            .await
            .is_ok()
    })
    .await;
    assert_eq!(velocities(&rec), [1.0, 3.0, 4.0, 5.0, 6.0, 8.0]);
    // Out of range is named.
    let err = plain_err(&s, "rome/robot/r1/base/go?suppress_ms=70000", &go(9.0)).await;
    assert_eq!(err["code"], "out_of_range", "{err}");
    assert!(
        err["message"].as_str().unwrap().contains("suppress_ms"),
        "{err}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_killed_holder_loses_the_lock_within_three_seconds() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let mut holder = peer!(rig.port, ["locker", "--robot", "r1"]);
    let stdout = holder.0.as_mut().unwrap().stdout.take().unwrap();
    let line = tokio::task::spawn_blocking(move || {
        let mut line = String::new();
        std::io::BufReader::new(stdout)
            .read_line(&mut line)
            .unwrap();
        line
    })
    .await
    .unwrap();
    let grant: serde_json::Value = serde_json::from_str(&line).unwrap();
    let fence = grant["fence"].as_u64().unwrap();

    let b = rig.client("b", 128).await;
    let queued = tokio::spawn(async move { b.go(7.0).await });
    eventually(Duration::from_secs(5), "b queued", || async {
        rig.queued().await == 1
    })
    .await;
    assert!(velocities(&rec).is_empty());
    let killed = Instant::now();
    holder.kill();
    queued.await.unwrap().unwrap();
    let took = killed.elapsed();
    assert!(took < Duration::from_secs(3), "released after {took:?}");
    assert_eq!(velocities(&rec), [7.0]);
    let s = rig.peer_session().await;
    let err = plain_err(&s, &format!("rome/robot/r1/base/stop?fence={fence}"), "").await;
    assert_eq!(err["code"], "stale_fence");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_repeated_request_id_is_answered_again_without_acting_twice() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let s = rig.peer_session().await;
    let go = |op: &'static str, v: u32| {
        let s = s.clone();
        async move {
            plain(
                &s,
                &format!("rome/robot/r1/base/go?op={op}"),
                &format!("{{\"velocity_mm_s\":{v}}}"),
            )
            .await
        }
    };
    let first = go("a1", 100).await.unwrap();
    // The reply was "lost": the same request comes again, twice.
    assert_eq!(go("a1", 100).await.unwrap(), first);
    assert_eq!(go("a1", 100).await.unwrap(), first);
    assert_eq!(velocities(&rec), [100.0]);
    // A refused request is refused again the same way, not retried.
    let bad = plain(&s, "rome/robot/r1/base/go?op=a2", "{}")
        .await
        .unwrap_err();
    assert_eq!(
        plain(&s, "rome/robot/r1/base/go?op=a2", "{}")
            .await
            .unwrap_err(),
        bad
    );
    // Another id acts again; the client library gives every command that
    // acts an id of its own.
    go("a3", 100).await.unwrap();
    rig.client("c", 128).await.go(200.0).await.unwrap();
    rig.client("c", 128).await.go(200.0).await.unwrap();
    assert_eq!(velocities(&rec), [100.0, 100.0, 200.0, 200.0]);
    // The server's own count: four carried out, two repeats answered.
    let stats = plain(&s, "rome/robot/r1/base/stats", "").await.unwrap();
    assert_eq!(
        stats,
        serde_json::json!({"executed": 4, "with_id": 4, "answered_from_memory": 2, "ids_executed_twice": 0, "suppressed": 0})
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_full_queue_behind_a_lock_answers_busy_and_serves_the_rest_afterwards() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let holder = rig.client("holder", 128).await;
    let lock = holder.lock().await.unwrap();
    let cap = rome_hardware::server::EVENT_QUEUE;
    // Those queued wait far longer than the busy answers can take to come
    // on a loaded machine: a queued request whose wait ran out would be
    // answered "locked", neither done nor busy.
    let session = NetOptions::loopback_client(rig.port).open().await.unwrap();
    let mut o = RobotOptions::new("flood");
    o.queue_wait = Duration::from_secs(300);
    let c = RobotClient::connect(&session, "r1", o).await.unwrap();
    let waiting: Vec<_> = (0..cap + 20)
        .map(|_| {
            let c = c.clone();
            tokio::spawn(async move { c.go(1.0).await })
        })
        .collect();
    // Those that found the queue full are answered at once; the rest wait.
    eventually(Duration::from_secs(30), "20 answered busy", || async {
        waiting.iter().filter(|w| w.is_finished()).count() == 20
    })
    .await;
    assert!(velocities(&rec).is_empty());
    lock.unlock().await.unwrap();
    let (mut ok, mut busy) = (0, 0);
    for w in waiting {
        match w.await.unwrap() {
            Ok(_) => ok += 1,
            Err(ClientError::Server(e)) if e.code == ErrorCode::Busy => {
                assert!(e.message.contains("requests queued"), "{e}");
                busy += 1;
            }
            Err(e) => panic!("neither done nor busy: {e}"),
        }
    }
    assert_eq!((ok, busy), (cap, 20));
    assert_eq!(velocities(&rec).len(), cap);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_base_set_moving_by_a_client_that_goes_away_is_stopped() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let moves = |rec: &Recorder| -> Vec<BaseOp> { rec.ops.lock().unwrap().clone() };
    let stops = |rec: &Recorder| {
        moves(rec)
            .iter()
            .filter(|op| matches!(op, BaseOp::Stop(_)))
            .count()
    };

    // A controller sets the base going and dies: the base stops.
    let driver = rig.client("driver", 128).await;
    driver.go(300.0).await.unwrap();
    drop(driver);
    eventually(Duration::from_secs(10), "the base stopped", || async {
        stops(&rec) == 1
    })
    .await;

    // A one-shot tool (no deadman) leaves the base going when it exits;
    // a later controller that dies stops it, and only that one.
    let session = NetOptions::loopback_client(rig.port).open().await.unwrap();
    let mut o = RobotOptions::new("cli");
    o.deadman = false;
    let tool = RobotClient::connect(&session, "r1", o).await.unwrap();
    tool.go(200.0).await.unwrap();
    drop(tool);
    session.close().await.unwrap();
    let driver = rig.client("driver", 128).await;
    driver.go(100.0).await.unwrap();
    drop(driver);
    eventually(
        Duration::from_secs(10),
        "the base stopped again",
        || async { stops(&rec) == 2 },
    )
    .await;
    assert_eq!(
        moves(&rec),
        [
            BaseOp::Go(300.0),
            BaseOp::Stop(false),
            BaseOp::Go(200.0),
            BaseOp::Go(100.0),
            BaseOp::Stop(false)
        ]
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_cut_off_holder_loses_the_lock_within_three_seconds() {
    let rec = Recorder::default();
    let rig = Harness::recorder(&rec, false).await;
    let (relay, far) = rome_tests::far_session(rig.port, Duration::ZERO).await;
    let holder = RobotClient::connect(&far, "r1", RobotOptions::new("far"))
        .await
        .unwrap();
    let lock = holder.lock().await.unwrap();

    let b = rig.client("b", 128).await;
    let queued = tokio::spawn(async move { b.go(7.0).await });
    eventually(Duration::from_secs(5), "b queued", || async {
        rig.queued().await == 1
    })
    .await;
    let cut_at = Instant::now();
    relay.pause();
    queued.await.unwrap().unwrap();
    let took = cut_at.elapsed();
    assert!(took < Duration::from_secs(3), "released after {took:?}");
    assert_eq!(velocities(&rec), [7.0]);
    drop(lock);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn unlocking_a_lock_a_restarted_server_forgot_is_not_an_error() {
    // No storage: the new server starts with the lock free.
    let rec = Recorder::default();
    let mut rig = Harness::recorder(&rec, false).await;
    let a = rig.client("a", 128).await;
    let lock = a.lock().await.unwrap();
    rig.servers.pop().unwrap().stop().await.unwrap();
    rig.start_base(&rec).await;
    // Commands under the old fence are refused: the lock is gone …
    let err = a.go(1.0).await.unwrap_err();
    assert_eq!(err.code(), Some(ErrorCode::StaleFence), "{err}");
    // … and releasing it has nothing left to do.
    lock.unlock().await.unwrap();
    a.go(2.0).await.unwrap();
    assert_eq!(velocities(&rec), [2.0]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_restarted_server_knows_the_holder_and_its_fence_from_the_storage() {
    let rec = Recorder::default();
    let mut rig = Harness::recorder(&rec, true).await;
    let a = rig.client("a", 128).await;
    let lock = a.lock().await.unwrap();
    let fence = lock.fence();
    a.go(1.0).await.unwrap();

    rig.servers.pop().unwrap().stop().await.unwrap();
    rig.start_base(&rec).await;

    // The holder's fence still works on the new server …
    a.go(2.0).await.unwrap();
    // … and the state shows it as the holder.
    let state = a.state().await.unwrap();
    let s = state.next().await.unwrap().unwrap();
    assert_eq!(s.lock.unwrap().fence, fence);
    // Others still wait, and an older fence is stale.
    let s2 = rig.peer_session().await;
    let err = plain_err(
        &s2,
        &format!("rome/robot/r1/base/go?fence={}", fence - 1),
        r#"{"velocity_mm_s":3}"#,
    )
    .await;
    assert_eq!(err["code"], "stale_fence");
    lock.unlock().await.unwrap();
    // The next grant goes above the stored fence.
    let again = a.lock().await.unwrap();
    assert_eq!(again.fence(), fence + 1);
    assert_eq!(velocities(&rec), [1.0, 2.0]);
}

/// A storage slow to answer is asked again: the restarted server does not
/// start with the lock free, which would make the holder's fence stale.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_restarted_server_asks_a_silent_storage_again_for_its_lock_record() {
    let rec = Recorder::default();
    let mut rig = Harness::empty(Some(Duration::from_millis(20))).await;
    // A storage that leaves the first query unanswered (held, so it is
    // not finished either) and answers the next ones with a record.
    let record = LockRecord {
        holder: Some(LockInfo {
            holder: "gone-1".into(),
            fence: 41,
        }),
        last_fence: 41,
        ttl_ms: 60_000,
    };
    let unanswered = Arc::new(Mutex::new(Vec::new()));
    let held = unanswered.clone();
    let storage = rig.peer_session().await;
    let _queryable = storage
        .declare_queryable(Root::default().store_all())
        .callback(move |q: zenoh::query::Query| {
            let mut held = held.lock().unwrap();
            if held.is_empty() && !q.parameters().contains_key("probe") {
                held.push(q);
                return;
            }
            let key = q.key_expr().clone();
            q.reply(key, rome_schema::encode(&record)).wait().unwrap();
        })
        .await
        .unwrap();
    // The server's session must know the storage before the server asks.
    let probe = "rome/store/robot/r1/base/lock?probe";
    let session = rig.session.clone();
    eventually(Duration::from_secs(5), "the storage reached", || async {
        let replies = session.get(probe).await.unwrap();
        matches!(replies.recv_async().await, Ok(r) if r.result().is_ok())
    })
    .await;
    rig.start_base(&rec).await;
    assert_eq!(
        unanswered.lock().unwrap().len(),
        1,
        "the first query was left unanswered"
    );
    let c = rig.client("c", 128).await;
    let state = c.state().await.unwrap();
    let s = state.next().await.unwrap().unwrap();
    assert_eq!(
        s.lock,
        Some(LockInfo {
            holder: "gone-1".into(),
            fence: 41
        }),
        "the record from the second answer"
    );
    let err = plain_err(
        &rig.peer_session().await,
        "rome/robot/r1/base/go?fence=40",
        r#"{"velocity_mm_s":3}"#,
    )
    .await;
    assert_eq!(err["code"], "stale_fence");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn virtual_coordinates_unwrap_16_bit_registers_both_ways() {
    let rec = Recorder::default();
    // Up past +32767 in 4 m steps, then down past -32768.
    let mut path: Vec<i64> = (0..30).map(|i| 20_000 + i * 4_000).collect();
    path.extend((0..60).map(|i| 136_000 - i * 4_000));
    rec.xs
        .lock()
        .unwrap()
        .extend(path.iter().map(|mm| mm.rem_euclid(65_536) as u16 as i16));
    let mut rig = Harness::empty(None).await;
    // No state stream: every register value is read by a `pose` request.
    rig.start_base(&rec).await;
    let c = rig.client("c", 128).await;
    let mut seen = Vec::new();
    while !rec.xs.lock().unwrap().is_empty() {
        seen.push(i64::from(c.pose().await.unwrap().x_mm));
    }
    let last = *seen.last().unwrap();
    assert_eq!(last, *path.last().unwrap());
    let p = c.pose().await.unwrap();
    assert_eq!(i64::from(p.x_mm), -100_000);
    assert!(p.wraps_x < 0, "{p:?}");
    let want: Vec<i64> = path[..seen.len()].to_vec();
    assert_eq!(seen, want, "every read unwrapped exactly");
}

async fn plain_err(s: &Session, selector: &str, payload: &str) -> serde_json::Value {
    match plain(s, selector, payload).await {
        Err(e) => e,
        Ok(v) => panic!("{selector}: expected an error, got {v}"),
    }
}

async fn plain(
    s: &Session,
    selector: &str,
    payload: &str,
) -> Result<serde_json::Value, serde_json::Value> {
    let mut get = s.get(selector).timeout(Duration::from_secs(5));
    if !payload.is_empty() {
        get = get.payload(payload);
    }
    let replies = get.await.unwrap();
    let reply = replies.recv_async().await.expect("a reply");
    match reply.result() {
        Ok(sample) => Ok(serde_json::from_slice(&sample.payload().to_bytes()).unwrap()),
        Err(e) => Err(serde_json::from_slice(&e.payload().to_bytes()).unwrap()),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn every_base_command_as_plain_zenoh_json_and_bad_input_named() {
    let rig = Harness::sim(Duration::from_millis(500)).await;
    // A plain Zenoh session built by hand: no RoME code on this side.
    let mut config = zenoh::Config::default();
    config.insert_json5("mode", r#""client""#).unwrap();
    config
        .insert_json5(
            "connect/endpoints",
            &format!(r#"["tcp/127.0.0.1:{}"]"#, rig.port),
        )
        .unwrap();
    config
        .insert_json5("scouting/multicast/enabled", "false")
        .unwrap();
    let z = zenoh::open(config).await.unwrap();
    let k = |c: &str| format!("rome/robot/r1/base/{c}");

    let ok = |v: Result<serde_json::Value, serde_json::Value>| v.unwrap_or_else(|e| panic!("{e}"));
    assert_eq!(
        ok(plain(&z, &k("set-bumper"), r#"{"watch":true}"#).await)["command"],
        "set-bumper"
    );
    assert_eq!(ok(plain(&z, &k("bumper"), "").await)["watch"], true);
    ok(plain(
        &z,
        &k("set-pose"),
        r#"{"x_mm":1000,"y_mm":2000,"heading_deg":90}"#,
    )
    .await);
    let p = ok(plain(&z, &k("pose"), "").await);
    assert_eq!(
        (p["x_mm"].as_i64(), p["y_mm"].as_i64()),
        (Some(1000), Some(2000))
    );
    assert_eq!(p["heading_deg"].as_f64(), Some(90.0));
    ok(plain(
        &z,
        &k("adjust-pose"),
        r#"{"dx_mm":-500,"dheading_deg":1.5}"#,
    )
    .await);
    let p = ok(plain(&z, &k("pose"), "").await);
    assert_eq!(p["x_mm"].as_i64(), Some(500));
    assert_eq!(p["heading_deg"].as_f64(), Some(91.5));
    assert_eq!(
        ok(plain(&z, &k("go"), r#"{"velocity_mm_s":200}"#).await)["mode"],
        "go"
    );
    assert_eq!(ok(plain(&z, &k("speed"), "").await)["speed_mm_s"], 200.0);
    assert!(ok(plain(&z, &k("wheel-speed"), "").await)["wheel_speed_mm_s"].is_number());
    assert_eq!(
        ok(plain(&z, &k("jog"), r#"{"rate_deg_s":-4}"#).await)["mode"],
        "jog"
    );
    assert_eq!(ok(plain(&z, &k("mode"), "").await)["mode"], "jog");
    assert_eq!(
        ok(plain(&z, &k("turn"), r#"{"degrees":30}"#).await)["mode"],
        "point_turn"
    );
    assert_eq!(
        ok(plain(&z, &k("move"), r#"{"distance_mm":-300,"velocity_mm_s":-1}"#).await)["mode"],
        "point_go"
    );
    assert_eq!(
        ok(plain(&z, &k("stop"), r#"{"emergency":true}"#).await)["command"],
        "stop"
    );
    let g = ok(plain(&z, &format!("{}?owner=plain;ttl_ms=1000", k("lock")), "").await);
    let fence = g["fence"].as_u64().unwrap();
    ok(plain(&z, &format!("{}?fence={fence}", k("stop")), "").await);
    assert_eq!(
        ok(plain(&z, &format!("{}?fence={fence}", k("unlock")), "").await)["released"],
        true
    );

    // Proximity and cameras.
    let sonar = ok(plain(&z, "rome/robot/r1/proximity/sonar", "").await);
    assert_eq!(sonar["sonar_mm"].as_array().unwrap().len(), 24);
    assert_eq!(
        ok(plain(&z, "rome/robot/r1/proximity/ir", "").await)["ir"]
            .as_array()
            .unwrap()
            .len(),
        24
    );
    let t = ok(plain(&z, "rome/robot/r1/proximity/timeout", r#"{"max_mm":3000}"#).await);
    assert!(t["max_mm"].as_array().unwrap().iter().all(|v| v == 3000));
    assert_eq!(
        ok(plain(&z, "rome/robot/r1/camera/up/size", "").await)["width"],
        512
    );

    // Bad input: each error names what was wrong.
    let cases: &[(&str, &str, &str, &str)] = &[
        ("rome/robot/r1/base/fly", "", "unknown_key", "fly"),
        (
            "rome/robot/r1/base/go",
            r#"{"velocity_mm_s":"fast"}"#,
            "wrong_type",
            "velocity_mm_s",
        ),
        ("rome/robot/r1/base/go", "{not json", "bad_json", "go"),
        (
            "rome/robot/r1/base/go",
            r#"{"velocity_mm_s":1,"x":2}"#,
            "bad_json",
            "x",
        ),
        (
            "rome/robot/r1/base/go",
            r#"{"velocity_mm_s":9000}"#,
            "out_of_range",
            "velocity",
        ),
        ("rome/robot/r1/base/move", "", "bad_json", "distance_mm"),
        (
            "rome/robot/r1/base/pose?priority=900",
            "",
            "out_of_range",
            "priority",
        ),
        (
            "rome/robot/r1/base/pose?speed=2",
            "",
            "bad_parameter",
            "speed",
        ),
        ("rome/robot/r1/base/unlock", "", "bad_parameter", "fence"),
        ("rome/robot/r1/base/stop?fence=12", "", "stale_fence", "12"),
        (
            "rome/robot/r1/proximity/timeout",
            r#"{"max_mm":[1,2]}"#,
            "wrong_type",
            "24",
        ),
        (
            "rome/robot/r1/proximity/timeout",
            r#"{"max_mm":50000}"#,
            "out_of_range",
            "50000",
        ),
        ("rome/robot/r1/proximity/lock", "", "unknown_key", "lock"),
        (
            "rome/robot/r1/camera/up/rows?rows=10,999",
            "",
            "out_of_range",
            "999",
        ),
        (
            "rome/robot/r1/camera/up/rows?rows=a",
            "",
            "wrong_type",
            "rows",
        ),
        (
            "rome/robot/r1/camera/up/grab?format=gif",
            "",
            "bad_parameter",
            "gif",
        ),
    ];
    for (selector, payload, code, names) in cases {
        let e = plain_err(&z, selector, payload).await;
        assert_eq!(e["code"], *code, "{selector} {payload}: {e}");
        let msg = e["message"].as_str().unwrap();
        assert!(
            msg.contains(names),
            "{selector}: '{msg}' should name '{names}'"
        );
    }
    // And the server still serves.
    ok(plain(&z, &k("pose"), "").await);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn camera_rows_come_in_one_request_and_a_lock_freezes_grabbing() {
    let rig = Harness::sim(Duration::from_millis(100)).await;
    let c = rig.client("tracker", 128).await;
    let size = c.camera_size("up").await.unwrap();
    assert_eq!((size.width, size.height), (512, 482));
    let full = c.camera_grab("up").await.unwrap();
    assert_eq!(full.pixels.len(), 512 * 482);
    let rows = c.camera_rows("up", &[120, 241, 360]).await.unwrap();
    assert_eq!(rows.rows, [120, 241, 360]);
    assert_eq!(rows.pixels.len(), 3 * 512);
    // `format=png` answers a PNG of the same frame size.
    let s = rig.peer_session().await;
    let replies = s
        .get("rome/robot/r1/camera/up/grab?format=png")
        .await
        .unwrap();
    let png = replies.recv_async().await.unwrap().into_result().unwrap();
    assert_eq!(png.encoding(), &zenoh::bytes::Encoding::IMAGE_PNG);
    let bytes = png.payload().to_bytes();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
    // IHDR: width and height, big-endian, at bytes 16..24.
    assert_eq!(&bytes[16..24], [0, 0, 2, 0, 0, 0, 1, 226]);

    let lock = c.camera_lock("up").await.unwrap();
    let frozen = c.camera_rows("up", &[0]).await.unwrap().frame;
    // Five grab periods pass; the frame must not change while locked.
    let window = Instant::now();
    while window.elapsed() < Duration::from_millis(500) {
        assert_eq!(c.camera_rows("up", &[0]).await.unwrap().frame, frozen);
    }
    // Another client's grab waits for the lock.
    let other = rig.client("other", 128).await;
    let waiting = tokio::spawn(async move { other.camera_rows("up", &[0]).await });
    lock.unlock().await.unwrap();
    waiting.await.unwrap().unwrap();
    eventually(Duration::from_secs(5), "grabbing resumes", || async {
        c.camera_rows("up", &[0]).await.unwrap().frame > frozen
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn one_server_killed_leaves_the_others_serving() {
    let mut rig = Harness::sim(Duration::from_millis(500)).await;
    let c = rig.client("c", 128).await;
    let side = rig.servers.pop().unwrap();
    assert!(side.label().contains("side"));
    side.abort();
    let root = Root::default();
    eventually(
        Duration::from_secs(5),
        "side camera gone from rome ls",
        || async {
            let alive =
                rome_client::alive::list(&c_session(&rig).await, &root, Duration::from_millis(500))
                    .await
                    .unwrap();
            let ids: Vec<String> = alive
                .iter()
                .map(|p| format!("{}/{}", p.role, p.id))
                .collect();
            !ids.contains(&"robot/r1/camera/side".to_string())
                && ids.contains(&"robot/r1/camera/up".to_string())
                && ids.contains(&"robot/r1/base".to_string())
                && ids.contains(&"robot/r1/proximity".to_string())
        },
    )
    .await;
    assert!(matches!(
        c.camera_size("side").await,
        Err(ClientError::NoReply { .. })
    ));
    c.pose().await.unwrap();
    c.sonar().await.unwrap();
    c.camera_size("up").await.unwrap();
}

async fn c_session(rig: &Harness) -> Session {
    NetOptions::loopback_client(rig.port).open().await.unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn the_scan_stream_follows_the_sonar_period_and_timeouts_cap_ranges() {
    let rig = Harness::sim(Duration::from_millis(500)).await;
    let c = rig.client("c", 128).await;
    let scans = c.scans().await.unwrap();
    let first = scans.next().await.unwrap().unwrap();
    let mut last = first.clone();
    for _ in 0..10 {
        last = scans.next().await.unwrap().unwrap();
    }
    assert_eq!(last.seq, first.seq + 10, "no scan lost");
    // The simulated ring fires every 100 ms of world time.
    assert_eq!(last.time_ms - first.time_ms, 1000);
    c.set_timeout([1_000; 24]).await.unwrap();
    eventually(Duration::from_secs(5), "ranges capped at 1000", || async {
        c.sonar()
            .await
            .unwrap()
            .sonar_mm
            .iter()
            .all(|r| *r <= 1_000)
    })
    .await;
    let err = c.set_timeout([20_000; 24]).await.unwrap_err();
    assert_eq!(err.code(), Some(ErrorCode::OutOfRange));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_short_scan_published_by_anyone_is_skipped_by_readers() {
    let rig = Harness::sim(Duration::from_millis(500)).await;
    let c = rig.client("reader", 128).await;
    let scans = c.scans().await.unwrap();
    let first = scans.next().await.unwrap().unwrap();
    // Someone else publishes garbage on the scan key: three readings.
    let intruder = rig.peer_session().await;
    let short = r#"{"robot":"r1","seq":999999,"time_ms":1,"sonar_mm":[1,2,3],"ir":[0,0,0]}"#;
    let e = rome_schema::decode::<rome_schema::robot::Scan>(short.as_bytes(), "scan").unwrap_err();
    assert!(e.to_string().contains("expected 24 readings"), "{e}");
    for _ in 0..3 {
        intruder
            .put("rome/robot/r1/proximity/scan", short)
            .await
            .unwrap();
    }
    // The reader goes on with the server's scans, every one of 24.
    for _ in 0..5 {
        let s = scans.next().await.unwrap().unwrap();
        assert_eq!((s.sonar_mm.len(), s.ir.len()), (24, 24));
        assert!(s.seq > first.seq && s.seq != 999_999);
    }
    let newest = scans.latest().await.unwrap().unwrap();
    assert_eq!(newest.sonar_mm.len(), 24);
    assert_eq!(scans.skipped(), 3, "each bad scan is counted once");
}

/// A camera "server" anyone could start: it answers `rows` with the reply
/// given, whatever was asked.
async fn hostile_camera(
    s: &Session,
    schema: &'static str,
    bytes: Vec<u8>,
) -> zenoh::query::Queryable<()> {
    s.declare_queryable("rome/robot/r9/camera/up/**")
        .callback(move |q| {
            let key = q.key_expr().clone();
            let enc = zenoh::bytes::Encoding::APPLICATION_OCTET_STREAM.with_schema(schema);
            let _ = q.reply(key, bytes.clone()).encoding(enc).wait();
        })
        .await
        .unwrap()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_camera_reply_with_other_rows_or_an_absurd_size_is_refused() {
    let (server, port) = open_loopback_peer(&[]).await.unwrap();
    let client_session = NetOptions::loopback_client(port).open().await.unwrap();
    let c = RobotClient::connect(&client_session, "r9", RobotOptions::new("reader"))
        .await
        .unwrap();
    // Asked for rows 1 and 2, sent rows 5 and 6: row(0) is not row 1.
    let q = hostile_camera(
        &server,
        "gray8 width=4 height=10 frame=1 time_ms=1 rows=5,6",
        vec![7; 8],
    )
    .await;
    let e = c.camera_rows("up", &[1, 2]).await.unwrap_err();
    assert!(e.to_string().contains("not the rows asked for"), "{e}");
    drop(q);
    // Four billion rows of no columns: nothing may be built on that.
    let q = hostile_camera(
        &server,
        "gray8 width=0 height=4000000000 frame=1 time_ms=1",
        Vec::new(),
    )
    .await;
    let e = c.camera_grab("up").await.unwrap_err();
    assert!(e.to_string().contains("width and height"), "{e}");
    drop(q);
    // A width past 2^32 once read as 1.
    let q = hostile_camera(
        &server,
        "gray8 width=4294967297 height=2 frame=1 time_ms=1",
        vec![0; 2],
    )
    .await;
    assert!(c.camera_grab("up").await.is_err());
    drop(q);
    // A well-formed reply still reads.
    let _q = hostile_camera(
        &server,
        "gray8 width=4 height=10 frame=1 time_ms=1 rows=1,2",
        vec![7; 8],
    )
    .await;
    let img = c.camera_rows("up", &[1, 2]).await.unwrap();
    assert_eq!(img.row(1), Some(&[7u8; 4][..]));
    assert_eq!(img.row(2), None);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn in_lock_step_a_grant_and_a_queued_request_last_simulated_time() {
    // A base server that is a participant of a lock-step clock: however
    // long the world stands still by the wall clock, its lock and its
    // queue wait for simulated time to pass.
    let clock = rome_clock::LockStep::new(0);
    let (session, _) = Harness::session().await;
    let rec = Recorder::default();
    let config = ServerConfig::new(&Root::default(), "r1", Device::Base).unwrap();
    let _server = {
        let (session, rec) = (session.clone(), rec.clone());
        clock
            .participate("the test's server", async move {
                robot::spawn(&session, config, Base::new("r1", rec, None))
            })
            .await
    };
    let rig = Harness {
        port: 0,
        state: None,
        session: session.clone(),
        servers: Vec::new(),
        _stepper: None,
    };
    rig.await_alive("base").await;
    let step_to = |t: u64| {
        let clock = clock.clone();
        async move {
            while clock.now_ms() < t {
                clock.settled().await;
                clock.try_advance(|| clock.now_ms() + 50).await;
            }
            clock.settled().await;
        }
    };

    let grant = plain(&session, "rome/robot/r1/base/lock?owner=a;ttl_ms=300", "")
        .await
        .unwrap();
    let fence = grant["fence"].as_u64().unwrap();
    let queued = {
        let s = session.clone();
        tokio::spawn(async move { plain(&s, "rome/robot/r1/base/mode?wait_ms=1000", "").await })
    };
    let go = |v: u32| {
        let s = session.clone();
        async move {
            plain(
                &s,
                &format!("rome/robot/r1/base/go?fence={fence}"),
                &format!(r#"{{"velocity_mm_s":{v}}}"#),
            )
            .await
        }
    };
    // The holder's command comes after the queued request on the same
    // session, so the request is in the queue once it is answered.
    go(1).await.unwrap();
    // Twice the grant's and more than the wait's lifetime by the wall clock.
    std::thread::sleep(Duration::from_millis(1_200));
    step_to(200).await;
    assert!(
        !queued.is_finished(),
        "a queued request ended with the clock at 200 ms"
    );
    go(2)
        .await
        .expect("the grant lives 300 simulated ms from its last use");
    assert_eq!(velocities(&rec), [1.0, 2.0]);

    // Not renewed from 200 ms on: it lapses at 500 ms, and the request
    // queued behind it is served.
    step_to(600).await;
    assert!(
        queued.await.unwrap().is_ok(),
        "the queued request is served"
    );
    let err = go(3).await.expect_err("the grant has lapsed");
    assert_eq!(err["code"], "stale_fence", "{err}");
    assert_eq!(velocities(&rec), [1.0, 2.0]);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_read_sent_right_behind_commands_sees_them_carried_out() {
    // A plain read is answered from the queryable's callback when nothing
    // is queued or being handled; one that arrives while set-poses sent
    // just before it are still in the queue must wait its turn.
    let rig = Harness::sim(Duration::from_millis(500)).await;
    let z = rig.peer_session().await;
    let k = |c: &str| format!("rome/robot/r1/base/{c}");
    for round in 0..40i64 {
        let mut sets = Vec::new();
        let mut x = 0;
        for j in 0..25 {
            x = round * 100 + j;
            let set = z
                .get(k("set-pose"))
                .payload(format!(r#"{{"x_mm":{x},"y_mm":{},"heading_deg":0}}"#, -x))
                .timeout(Duration::from_secs(5))
                .await
                .unwrap();
            sets.push(set);
        }
        // Sent before the set-poses' answers are back.
        let pose = plain(&z, &k("pose"), "").await.unwrap();
        let (px, py) = (
            pose["x_mm"].as_i64().unwrap(),
            pose["y_mm"].as_i64().unwrap(),
        );
        assert!(
            (px - x).abs() <= 1 && (py + x).abs() <= 1,
            "round {round}: the read overtook set-poses sent before it: {pose}"
        );
        for set in sets {
            let done = set.recv_async().await.unwrap();
            assert!(done.result().is_ok(), "a set-pose of round {round} failed");
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn a_read_waits_behind_a_held_lock_like_any_request() {
    // The quick path for reads must not pass another client's lock: the
    // read waits in the queue until the lock goes, or times out there.
    let rig = Harness::sim(Duration::from_millis(500)).await;
    let z = rig.peer_session().await;
    let pose = "rome/robot/r1/base/pose";
    // Served at once while nobody holds the lock.
    plain(&z, pose, "").await.unwrap();
    let holder = rig.client("holder", 128).await;
    let lock = holder.lock().await.unwrap();
    let e = plain_err(&z, &format!("{pose}?wait_ms=300"), "").await;
    assert_eq!(e["code"], "timed_out", "{e}");
    assert!(
        e["message"].as_str().unwrap().contains("behind the lock"),
        "{e}"
    );
    // Queued behind the lock, then served once it is released.
    let z2 = z.clone();
    let waiting =
        tokio::spawn(async move { plain(&z2, "rome/robot/r1/base/pose?wait_ms=5000", "").await });
    eventually(Duration::from_secs(5), "read queued", || async {
        rig.queued().await == 1
    })
    .await;
    lock.unlock().await.unwrap();
    waiting.await.unwrap().unwrap();
}

/// Clients and the servers' holds tell reads from changes by
/// `rome_schema::robot::READS`; each server lists its own reads: the two
/// must agree, or a read would be held as a change (or a change let
/// through as a read) in a run split into processes.
#[test]
fn every_read_a_server_lists_is_a_read_to_the_schema() {
    use rome_hardware::base::Base;
    use rome_hardware::camera::Camera;
    use rome_hardware::proximity::Proximity;
    use rome_hardware::server::Service;
    use rome_sim_hardware::world::{SimBase, SimCamera, SimProximity};
    let mut reads: Vec<&str> = Vec::new();
    reads.extend(<Base<SimBase> as Service>::READS);
    reads.extend(<Proximity<SimProximity> as Service>::READS);
    reads.extend(<Camera<SimCamera> as Service>::READS);
    assert!(reads.len() >= 8, "{reads:?}");
    for read in reads {
        assert!(
            rome_schema::robot::READS.contains(&read),
            "{read} is a read to its server but not in rome_schema::robot::READS"
        );
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hardware_server_refuses_another_protocol_by_name_and_says_its_version() {
    use rome_schema::version::{Speaks, PROTOCOL};
    let rig = Harness::sim(Duration::from_millis(500)).await;
    let session = c_session(&rig).await;
    let newer = Speaks {
        version: "9.0.0".into(),
        protocol: PROTOCOL + 1,
    };
    let reply = session
        .get("rome/robot/r1/base/pose")
        .attachment(newer.to_tag())
        .timeout(Duration::from_secs(5))
        .await
        .unwrap()
        .recv_async()
        .await
        .unwrap();
    let err = reply.result().expect_err("refused");
    let e: rome_schema::ErrorReply =
        rome_schema::decode(&err.payload().to_bytes(), "error reply").unwrap();
    assert_eq!(e.code, ErrorCode::Version, "{e}");
    assert!(e.message.contains("robot r1 base"), "names the server: {e}");
    assert!(e.message.contains(&Speaks::this().to_string()), "{e}");
    // A command of this build is served, and says the server's build.
    let c = rig.client("c", 128).await;
    c.pose().await.unwrap();
    let said = rome_client::alive::versions(&session, &Root::default(), Duration::from_secs(1))
        .await
        .unwrap();
    let base = said
        .iter()
        .find(|(k, _)| k == "rome/alive/server/robot/r1/base");
    assert_eq!(base.map(|(_, s)| s), Some(&Speaks::this()), "{said:?}");
}

#[test]
fn a_trace_shows_a_pose_that_differs_in_its_last_bit() {
    use rome_sim_hardware::trace::write_instant;
    let map = rome_maps::load_named("fig5_3").unwrap();
    let mut sim = rome_sim::Sim::new(&map, rome_sim::SimConfig::default());
    sim.add_robot_at("r1", "301L", -90.0).unwrap();
    sim.run_for(1_000);
    let mut a = Vec::new();
    write_instant(&sim, &mut a).unwrap();
    let x = sim.robot(0).pose.at.x;
    sim.robot_mut(0).pose.at.x = f64::from_bits(x.to_bits() ^ 1);
    let mut b = Vec::new();
    write_instant(&sim, &mut b).unwrap();
    assert_ne!(a, b, "one bit of x apart, the same line");
    let line = String::from_utf8(a).unwrap();
    let fields: Vec<&str> = line.split_whitespace().collect();
    assert_eq!(fields[0], "1000", "{line}");
    assert_eq!(fields.len(), 6 + rome_schema::robot::SONARS, "{line}");
    let read: f64 = fields[2].parse().unwrap();
    assert_eq!(read.to_bits(), x.to_bits(), "{line}");
}

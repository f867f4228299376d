//! A lock-step clock over the network: a message one follower sends
//! another, after the sender had already finished with the instant, is
//! still handled at the instant it was sent (the rounds of
//! `rome_sim_hardware::lockstep::Parties`).

use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::robot::{RobotClient, RobotOptions};
use rome_hardware::robot::Rates;
use rome_schema::Root;
use rome_sim::{Sim, SimConfig};
use rome_sim_hardware::lockstep::{publish_clock, start_lockstep_with, Parties};
use rome_sim_hardware::robot::spawn_sim_robot;
use rome_sim_hardware::world::SimWorld;
use std::time::Duration;

const POKE: &str = "test/rounds/poke";
const NEWS: &str = "test/rounds/news";

/// Three followers in separate sessions: an asker queries a server at
/// instant T; the server answers, then (50 ms of wall time later, long
/// after it had said it was done with T before the query came) publishes
/// news to a watcher. Without rounds the world has moved on by then and
/// the watcher reads the news at a later instant; with them it reads it at
/// T, the instant it was sent, however late it comes.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn news_sent_late_in_an_instant_is_read_at_that_instant() {
    late_news(true).await;
}

/// The same, with the server ending its run (and so leaving the clock)
/// right after it has published: its last message is still read at the
/// instant it was sent, since a party that leaves brings one more round.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn news_sent_just_before_its_sender_leaves_is_read_at_that_instant() {
    late_news(false).await;
}

/// Runs the three followers; `server_stays`: the server remains a party
/// until the news is read, else it leaves as soon as it has sent it.
async fn late_news(server_stays: bool) {
    let root = Root::default();
    let (hub, port) = open_loopback_peer(&[]).await.expect("hub on loopback");
    let map = rome_maps::load_named("fig5_3").expect("built-in map");
    let world = SimWorld::new(Sim::new(&map, SimConfig::default()));
    let clock = rome_clock::LockStep::new(world.lock().time_ms());
    let parties = Parties::follow(&hub, &root, &clock)
        .await
        .expect("parties followed");

    let session = || async {
        NetOptions::loopback_client(port)
            .open()
            .await
            .expect("follower session")
    };

    // The watcher: its subscription is declared before it joins the clock.
    let watcher = {
        let (s, root) = (session().await, root.clone());
        let news = s.declare_subscriber(NEWS).await.expect("subscriber");
        tokio::spawn(async move {
            rome_client::simtime::follow(&s, &root, "watcher", async {
                let sample = rome_clock::idle(news.recv_async())
                    .await
                    .expect("news arrives");
                let sent: u64 = String::from_utf8_lossy(&sample.payload().to_bytes())
                    .parse()
                    .expect("news is an instant");
                (sent, rome_clock::now_ms().expect("in simulated time"))
            })
            .await
            .expect("watcher follows the clock")
        })
    };
    // The server and the asker stay until the watcher has read the news.
    let (done_tx, done_server) = flume::bounded::<()>(1);
    let done_asker = done_server.clone();
    // The server: answers first, publishes later.
    let server = {
        let (s, root) = (session().await, root.clone());
        let pokes = s.declare_queryable(POKE).await.expect("queryable");
        tokio::spawn(async move {
            let inner = s.clone();
            rome_client::simtime::follow(&s, &root, "server", async move {
                let query = rome_clock::idle(pokes.recv_async()).await.expect("a poke");
                query.reply(POKE, "ok").await.expect("reply");
                // The query ends here: the asker has its answer now.
                drop(query);
                let at = rome_clock::now_ms().expect("in simulated time");
                rome_clock::busy(tokio::time::sleep(Duration::from_millis(50))).await;
                inner.put(NEWS, at.to_string()).await.expect("news sent");
                // Stays a party: one that leaves mid-instant is no longer
                // waited for, and its last messages with it.
                if server_stays {
                    let _ = rome_clock::idle(done_server.recv_async()).await;
                }
                at
            })
            .await
            .expect("server follows the clock")
        })
    };
    // The asker: pokes the server 100 ms into the run, once the server has
    // long said it is done with that instant.
    let asker = {
        let (s, root) = (session().await, root.clone());
        tokio::spawn(async move {
            let inner = s.clone();
            rome_client::simtime::follow(&s, &root, "asker", async move {
                rome_clock::sleep(Duration::from_millis(100)).await;
                rome_clock::busy(tokio::time::sleep(Duration::from_millis(20))).await;
                let replies = inner
                    .get(POKE)
                    .consolidation(zenoh::query::ConsolidationMode::None)
                    .await
                    .expect("poke sent");
                rome_clock::busy(replies.recv_async())
                    .await
                    .expect("poke answered");
                let at = rome_clock::now_ms().expect("in simulated time");
                let _ = rome_clock::idle(done_asker.recv_async()).await;
                at
            })
            .await
            .expect("asker follows the clock")
        })
    };

    // Hold the clock at its start until all three follow it, as
    // `rome sim --lockstep --parties 3` does.
    let _stepper = start_when_joined(&hub, &root, &world, &clock, parties, 3).await;

    let within = Duration::from_secs(30);
    let (sent, read) = tokio::time::timeout(within, watcher)
        .await
        .expect("watcher ends")
        .expect("watcher task");
    drop(done_tx);
    let asked = tokio::time::timeout(within, asker)
        .await
        .expect("asker ends");
    let answered = tokio::time::timeout(within, server)
        .await
        .expect("server ends");
    let (asked, answered) = (asked.expect("asker task"), answered.expect("server task"));
    assert_eq!(
        asked, answered,
        "the poke is answered at the instant it is sent"
    );
    assert_eq!(
        sent, answered,
        "the news carries the instant it was sent at"
    );
    assert_eq!(
        read, sent,
        "the news is read at the instant it was sent, not when it happened to arrive"
    );
}

/// Which of the two commanding followers is slow.
#[derive(Clone, Copy)]
enum Slow {
    Alpha,
    Beta,
}

/// Two followers, each its own session, command one simulated base at the
/// same instant: alpha sets 100 mm/s, beta 200 mm/s. One of them is slow:
/// its command leaves 80 ms of wall time after the other's. The base
/// serves them in the same order either way (by the senders' stable
/// names, not by arrival), so it is left at the same speed: served as they
/// arrive, the slow one's command would come last and win each time.
#[tokio::test(flavor = "multi_thread", worker_threads = 4)]
async fn commands_two_processes_send_one_base_at_one_instant_are_served_in_the_same_order_whichever_arrives_first(
) {
    let alpha_slow = speed_left(Slow::Alpha).await;
    let beta_slow = speed_left(Slow::Beta).await;
    assert!(
        [100.0, 200.0].contains(&alpha_slow),
        "the base is left at one of the two speeds, not {alpha_slow}"
    );
    assert_eq!(
        alpha_slow, beta_slow,
        "the same commands at the same instant leave the base at the same speed, whichever arrived first"
    );
}

/// Runs the two followers against a lock-step simulator with robot r1;
/// the speed both read back at the instant after their commands.
async fn speed_left(slow: Slow) -> f64 {
    let root = Root::default();
    let (hub, port) = open_loopback_peer(&[]).await.expect("hub on loopback");
    let world = rome_tests::world("fig5_3", SimConfig::default(), &[("r1", "301L")]);
    let clock = rome_clock::LockStep::new(world.lock().time_ms());
    let rates = Rates {
        state: Some(Duration::from_millis(100)),
        scan: Some(Duration::from_millis(100)),
        camera: Duration::from_secs(3_600),
    };
    let _servers = {
        let (hub, root, world) = (hub.clone(), root.clone(), world.clone());
        clock
            .participate("sim", async move {
                spawn_sim_robot(&hub, &root, &world, "r1", rates).expect("r1's servers")
            })
            .await
    };
    let parties = Parties::follow(&hub, &root, &clock)
        .await
        .expect("parties followed");

    let (done_tx, done_rx) = flume::bounded::<()>(1);
    let (read_tx, read_rx) = flume::unbounded::<f64>();
    let mut followers = Vec::new();
    for (name, speed, is_slow) in [
        ("alpha", 100.0, matches!(slow, Slow::Alpha)),
        ("beta", 200.0, matches!(slow, Slow::Beta)),
    ] {
        let s = NetOptions::loopback_client(port)
            .open()
            .await
            .expect("follower session");
        let (root, done, read) = (root.clone(), done_rx.clone(), read_tx.clone());
        followers.push(tokio::spawn(async move {
            rome_client::simtime::follow(&s, &root, name, async {
                let rc = RobotClient::connect(&s, "r1", RobotOptions::new(name))
                    .await
                    .expect("client of r1");
                rome_clock::sleep(Duration::from_millis(100)).await;
                if is_slow {
                    rome_clock::busy(tokio::time::sleep(Duration::from_millis(80))).await;
                }
                let sent_at = rome_clock::now_ms();
                rc.go(speed).await.expect("go carried out");
                assert_eq!(rome_clock::now_ms(), sent_at, "answered in its instant");
                rome_clock::sleep(Duration::from_millis(10)).await;
                let left = rc.speed().await.expect("speed read").speed_mm_s;
                read.send(left).expect("reported");
                // Both stay parties until both have read.
                let _ = rome_clock::idle(done.recv_async()).await;
            })
            .await
            .expect("follows the clock")
        }));
    }

    let _stepper = start_when_joined(&hub, &root, &world, &clock, parties, 2).await;
    let within = Duration::from_secs(30);
    let mut read = Vec::new();
    for _ in 0..2 {
        let left = tokio::time::timeout(within, read_rx.recv_async())
            .await
            .expect("both read within 30 s")
            .expect("a follower reports");
        read.push(left);
    }
    drop(done_tx);
    for f in followers {
        tokio::time::timeout(within, f)
            .await
            .expect("follower ends")
            .expect("follower task");
    }
    assert_eq!(read[0], read[1], "both read the speed the base was left at");
    read[0]
}

/// Holds the clock at its start until `n` followers follow it, as
/// `rome sim --lockstep --parties n` does, then steps the world with them.
async fn start_when_joined(
    hub: &zenoh::Session,
    root: &Root,
    world: &SimWorld,
    clock: &rome_clock::LockStep,
    parties: Parties,
    n: usize,
) -> rome_sim_hardware::world::Stepper {
    let start = rome_schema::sim::Clock::instant(clock.now_ms(), true);
    let held = tokio::time::Instant::now();
    while parties.len() < n {
        assert!(
            held.elapsed() < Duration::from_secs(20),
            "only {} of {n} followers joined",
            parties.len()
        );
        publish_clock(hub, &root.sim_clock(), &start)
            .await
            .expect("clock published");
        tokio::time::sleep(Duration::from_millis(50)).await;
    }
    start_lockstep_with(hub, root, world, clock, parties)
}

//! The elevator server (`<root>/building/elevator/<name>/…`): a call
//! brings the car and opens its doors; a floor it does not serve is
//! refused by name; one client rides at a time through the session, and
//! a rider that dies frees it and lets the doors it held close; a button pressed by
//! anyone is taken while someone else holds the session.

#![allow(clippy::unwrap_used)]

use rome_client::elevator::ElevatorClient;
use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::RobotOptions;
use rome_hardware::elevator::spawn_elevator;
use rome_hardware::ServerConfig;
use rome_schema::elevator::{Doors, ElevatorState};
use rome_schema::{ErrorCode, Root};
use rome_sim::elevator::{Car, CarSpec};
use rome_sim_hardware::elevator::SimCar;
use rome_tests::eventually;
use std::time::Duration;
use zenoh::Session;

/// A quick car: 0.3 s a floor, 0.1 s for the doors, 0.5 s open.
const QUICK: CarSpec = CarSpec {
    per_floor_ms: 300,
    doors_ms: 100,
    dwell_ms: 500,
};

struct Shaft {
    port: u16,
    _session: Session,
    _server: (rome_hardware::robot::Running, zenoh::pubsub::Subscriber<()>),
    _car: tokio::task::JoinHandle<()>,
}

/// Elevator `acs.elev` serving floors 3, 4 and 5, standing at 3.
async fn shaft() -> Shaft {
    let (session, port) = open_loopback_peer(&[]).await.unwrap();
    let floors = ["3", "4", "5"].map(String::from).to_vec();
    let car = SimCar::new(Car::new(floors, "3", QUICK).unwrap());
    let stepping = car.run(1.0);
    let config = ServerConfig::elevator(&Root::default(), "acs.elev").unwrap();
    let server = spawn_elevator(&session, config, car, Some(Duration::from_millis(20)))
        .await
        .unwrap();
    rome_tests::await_alive(&session, "rome/alive/server/building/elevator/acs.elev", 1).await;
    Shaft {
        port,
        _session: session,
        _server: server,
        _car: stepping,
    }
}

/// A client of `acs.elev` on a session of its own (closing it is the
/// client dying).
async fn rider(port: u16, role: &str) -> (Session, ElevatorClient) {
    let s = NetOptions::loopback_client(port).open().await.unwrap();
    let e = ElevatorClient::connect(&s, "acs.elev", RobotOptions::new(role))
        .await
        .unwrap();
    (s, e)
}

async fn state_is(e: &ElevatorClient, check: impl Fn(&ElevatorState) -> bool) -> bool {
    e.state().await.is_ok_and(|s| check(&s))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_call_brings_the_car_and_opens_its_doors() {
    let shaft = shaft().await;
    let (_s, e) = rider(shaft.port, "caller").await;
    let done = e.call("5").await.unwrap();
    assert_eq!(done.command, "call");
    assert_eq!(done.state.elevator, "acs.elev");
    assert_eq!(done.state.stops, ["5"]);
    eventually(Duration::from_secs(10), "the car opens at 5", || {
        state_is(&e, |s| {
            s.floor == "5" && s.doors == Doors::Open && !s.moving
        })
    })
    .await;
    // The stream says the same.
    let states = e.states().await.unwrap();
    let s = states.next().await.unwrap().unwrap();
    assert_eq!((s.floor.as_str(), s.floors.len()), ("5", 3));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_floor_it_does_not_serve_is_refused_by_name() {
    let shaft = shaft().await;
    let (_s, e) = rider(shaft.port, "caller").await;
    let err = e.go("7").await.unwrap_err();
    assert_eq!(err.code(), Some(ErrorCode::OutOfRange), "{err}");
    assert!(
        err.to_string()
            .contains("no floor '7' here: it serves 3, 4, 5"),
        "{err}"
    );
    // A payload on a command that takes none is refused by name.
    let raw = NetOptions::loopback_client(shaft.port)
        .open()
        .await
        .unwrap();
    let reply = raw
        .get("rome/building/elevator/acs.elev/open")
        .payload("{\"hold\":true}")
        .await
        .unwrap()
        .recv_async()
        .await
        .unwrap();
    let refusal = reply.result().expect_err("refused");
    let text = refusal.payload().try_to_string().unwrap().into_owned();
    assert!(text.contains("'open' takes no payload"), "{text}");
    // The server serves on.
    assert_eq!(e.state().await.unwrap().floor, "3");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_rides_at_a_time_and_a_rider_that_dies_frees_the_session_and_the_doors() {
    let shaft = shaft().await;
    let (first_session, first) = rider(shaft.port, "first").await;
    let (_s, second) = rider(shaft.port, "second").await;
    let ride = first.session().await.unwrap();
    first.open().await.unwrap();
    eventually(Duration::from_secs(10), "the doors are held open", || {
        state_is(&first, |s| {
            s.doors == Doors::Open && s.held && s.lock.is_some()
        })
    })
    .await;
    // The second's call waits behind the first's session.
    let mut call = tokio::spawn(async move { second.call("5").await.map(|d| (d, second)) });
    let early = tokio::time::timeout(Duration::from_millis(800), &mut call).await;
    assert!(
        early.is_err(),
        "the second's call was answered during the first's session"
    );
    // The first rider dies inside: its liveliness goes, and with it the
    // session; the doors it held close after the dwell, and the second's
    // call is served.
    first_session.close().await.unwrap();
    drop(ride);
    let (done, second) = tokio::time::timeout(Duration::from_secs(10), call)
        .await
        .expect("the second's call is served once the first is gone")
        .unwrap()
        .unwrap();
    assert_eq!(done.state.stops, ["5"]);
    eventually(
        Duration::from_secs(10),
        "the car leaves for 5 and opens there",
        || {
            state_is(&second, |s| {
                s.floor == "5" && s.doors == Doors::Open && !s.held
            })
        },
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_button_is_taken_while_another_client_holds_the_session() {
    let shaft = shaft().await;
    let (_a, holder) = rider(shaft.port, "holder").await;
    let (_b, operator) = rider(shaft.port, "operator").await;
    let _ride = holder.session().await.unwrap();
    operator.press("4").await.unwrap();
    eventually(Duration::from_secs(10), "the car stops at 4", || {
        state_is(&holder, |s| s.floor == "4" && s.doors != Doors::Closed)
    })
    .await;
    // A press that is not one is ignored; the buttons still work.
    let raw = NetOptions::loopback_client(shaft.port)
        .open()
        .await
        .unwrap();
    raw.put("rome/building/elevator/acs.elev/press", "{\"floor\":5")
        .await
        .unwrap();
    operator.press("5").await.unwrap();
    eventually(Duration::from_secs(10), "the car goes on to 5", || {
        state_is(&holder, |s| s.floor == "5")
    })
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn doors_held_by_a_rider_that_dies_close_after_the_dwell() {
    let shaft = shaft().await;
    let (rider_session, r) = rider(shaft.port, "rider").await;
    let (_w, watcher) = rider(shaft.port, "watcher").await;
    let ride = r.session().await.unwrap();
    r.open().await.unwrap();
    eventually(Duration::from_secs(10), "the doors are held open", || {
        state_is(&watcher, |s| s.doors == Doors::Open && s.held)
    })
    .await;
    rider_session.close().await.unwrap();
    drop(ride);
    eventually(
        Duration::from_secs(10),
        "the doors let go and close",
        || {
            state_is(&watcher, |s| {
                s.lock.is_none() && !s.held && s.doors == Doors::Closed
            })
        },
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_session_given_back_is_free_at_once_for_the_next_rider() {
    let shaft = shaft().await;
    let (_s1, first) = rider(shaft.port, "first").await;
    let (_s2, second) = rider(shaft.port, "second").await;
    let ride = first.session().await.unwrap();
    // The state stream says who rides.
    let states = first.states().await.unwrap();
    let held = states.next().await.unwrap().unwrap();
    assert_eq!(held.lock.map(|l| l.fence), Some(ride.fence()));
    // Given back: the next rider has it without waiting out a lapse (the
    // grant would outlive 2.5 s unrenewed).
    ride.unlock().await.unwrap();
    let next = tokio::time::timeout(Duration::from_secs(1), second.session())
        .await
        .expect("the next rider's session is granted at once")
        .unwrap();
    let shows_next = async {
        while let Some(Ok(s)) = states.next().await {
            if s.lock.map(|l| l.fence) == Some(next.fence()) {
                return;
            }
        }
    };
    tokio::time::timeout(Duration::from_secs(5), shows_next)
        .await
        .expect("the state stream names the next rider");
}

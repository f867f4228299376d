//! The P2OS driver against an emulated Pioneer on a pseudo terminal: the
//! bytes on the line, SIP decoding, and a robot that falls silent and
//! comes back.

#![allow(clippy::unwrap_used)]

use rome_hardware::device::{BaseDevice, BaseOp, ProximityDevice};
use rome_hardware::serial::emulator::Emulator;
use rome_hardware::serial::proto::{self, command, command_int};
use rome_hardware::serial::{P2os, P2osConfig};
use rome_schema::robot::{Move, Turn};
use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};
use tokio_serial::{SerialPort, SerialStream};

/// A pty pair: the emulator on the master side, the slave's path for the
/// driver. The slave handle is kept so the pty stays usable.
fn pty() -> (SerialStream, SerialStream, String) {
    let (master, slave) = SerialStream::pair().expect("a pseudo terminal");
    let path = slave.name().expect("the slave's path");
    (master, slave, path)
}

async fn until(what: &str, within: Duration, mut check: impl FnMut() -> bool) {
    let deadline = Instant::now() + within;
    while !check() {
        assert!(Instant::now() < deadline, "not within {within:?}: {what}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

fn config(path: &str) -> P2osConfig {
    P2osConfig {
        path: path.to_string(),
        baud: 115_200,
        answer_timeout: Duration::from_millis(500),
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_driver_speaks_p2os_byte_for_byte() {
    let (master, _slave, path) = pty();
    let emu = Emulator::default();
    tokio::spawn(emu.clone().run(master));
    let mut robot = P2os::start(config(&path));
    until("connected", Duration::from_secs(5), || robot.connected()).await;

    // The handshake [P2 6.5], exactly.
    let handshake: Vec<u8> = [
        vec![0xFA, 0xFB, 0x03, 0x02, 0x00, 0x02], // CLOSE
        vec![0xFA, 0xFB, 0x03, 0x00, 0x00, 0x00], // SYNC0
        vec![0xFA, 0xFB, 0x03, 0x01, 0x00, 0x01], // SYNC1
        vec![0xFA, 0xFB, 0x03, 0x02, 0x00, 0x02], // SYNC2
        vec![0xFA, 0xFB, 0x03, 0x01, 0x00, 0x01], // OPEN
        vec![0xFA, 0xFB, 0x06, 0x04, 0x3B, 0x01, 0x00, 0x05, 0x3B], // ENABLE 1
    ]
    .concat();
    until("handshake received", Duration::from_secs(2), || {
        emu.bytes().len() >= handshake.len()
    })
    .await;
    assert_eq!(emu.bytes()[..handshake.len()], handshake[..]);

    // Move 1000 mm at 300 mm/s: SETV 300 then MOVE 1000.
    let before = emu.bytes().len();
    robot
        .command(BaseOp::Move(Move {
            distance_mm: 1000.0,
            velocity_mm_s: 300.0,
            accel_mm_s2: -1.0,
        }))
        .await
        .unwrap();
    let want = [
        command_int(proto::SETV, 300),
        command_int(proto::MOVE, 1000),
    ]
    .concat();
    assert_eq!(
        want,
        [
            vec![0xFA, 0xFB, 0x06, 0x06, 0x3B, 0x2C, 0x01, 0x32, 0x3C],
            vec![0xFA, 0xFB, 0x06, 0x08, 0x3B, 0xE8, 0x03, 0xF0, 0x3E],
        ]
        .concat()
    );
    until("move sent", Duration::from_secs(2), || {
        emu.bytes()[before..].windows(want.len()).any(|w| w == want)
    })
    .await;
    // A clockwise turn is a negative DHEAD; an emergency stop is E_STOP.
    let before = emu.bytes().len();
    robot
        .command(BaseOp::Turn(Turn {
            degrees: 90.0,
            velocity_deg_s: -1.0,
            accel_deg_s2: -1.0,
        }))
        .await
        .unwrap();
    robot.command(BaseOp::Stop(true)).await.unwrap();
    let want = [command_int(proto::DHEAD, -90), command(proto::E_STOP)].concat();
    until("turn and stop sent", Duration::from_secs(2), || {
        emu.bytes()[before..].windows(want.len()).any(|w| w == want)
    })
    .await;

    // SIPs: odometry and sonar come back decoded.
    let moved = robot.command(BaseOp::Status).await.unwrap();
    let x = *emu.x_mm.lock().unwrap();
    assert!(
        (f64::from(moved.raw_x) - x).abs() <= 300.0,
        "{moved:?} vs {x}"
    );
    // Two SIPs carry the 16 sonars, eight each.
    let deadline = Instant::now() + Duration::from_secs(2);
    let scan = loop {
        let scan = robot.scan().await.unwrap();
        if scan.sonar_mm[..16].iter().all(|r| *r < 10_000) {
            break scan;
        }
        assert!(Instant::now() < deadline, "sonar not filled: {scan:?}");
        tokio::time::sleep(Duration::from_millis(10)).await;
    };
    assert_eq!(scan.sonar_mm[3], 1_300);
    assert_eq!(scan.sonar_mm[12], 2_200);
    *emu.bumpers.lock().unwrap() = 0b10; // front bumper 1
    let deadline = Instant::now() + Duration::from_secs(2);
    while robot.command(BaseOp::Status).await.unwrap().state.bumpers != 1 {
        assert!(Instant::now() < deadline, "front bumper not seen");
        tokio::time::sleep(Duration::from_millis(10)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_silent_robot_gives_errors_within_the_timeout_and_is_reconnected() {
    let (master, _slave, path) = pty();
    let emu = Emulator::default();
    tokio::spawn(emu.clone().run(master));
    let mut robot = P2os::start(config(&path));
    until("connected", Duration::from_secs(5), || robot.connected()).await;
    robot.command(BaseOp::Go(100.0)).await.unwrap();

    emu.silent.store(true, Ordering::Relaxed);
    let silent_at = Instant::now();
    let err = loop {
        match robot.command(BaseOp::Status).await {
            Err(e) => break e,
            Ok(_) => tokio::time::sleep(Duration::from_millis(10)).await,
        }
    };
    let took = silent_at.elapsed();
    assert!(took <= Duration::from_millis(800), "error after {took:?}");
    let text = err.to_string();
    assert!(
        text.contains(&path) && (text.contains("did not answer") || text.contains("not connected")),
        "{text}"
    );
    // Commands given meanwhile fail, and are not replayed later.
    assert!(robot.command(BaseOp::Go(999.0)).await.is_err());

    // The link gives the robot up and says why.
    until("link dropped", Duration::from_secs(2), || {
        !robot.connected()
    })
    .await;
    assert!(
        robot.last_error().contains("no server information packet"),
        "{}",
        robot.last_error()
    );

    let bytes_before = emu.bytes().len();
    emu.silent.store(false, Ordering::Relaxed);
    until("reconnected", Duration::from_secs(5), || {
        robot.connects() >= 2 && robot.connected()
    })
    .await;
    robot.command(BaseOp::Status).await.unwrap();
    let after = emu.bytes()[bytes_before..].to_vec();
    let sync0 = command(proto::SYNC0);
    assert!(
        after.windows(sync0.len()).any(|w| w == sync0),
        "a new handshake"
    );
    let stale = command_int(proto::VEL, 999);
    assert!(!after.windows(stale.len()).any(|w| w == stale), "no replay");
}

//! Every decoder that reads what another party sent, behind one signature,
//! `fn(&[u8])`, for the `cargo fuzz` targets in `fuzz/` and for the
//! property test in `tests/decoders.rs`. Each must return, whatever the
//! bytes: an error is fine, a panic is a bug.
//!
//! An input is split at its first two newlines into a key, selector
//! parameters and a payload, so one byte string drives all three.

use rome_data::cmd::Apply;
use rome_hardware::base::Base;
use rome_hardware::camera::Camera;
use rome_hardware::proximity::Proximity;
use rome_hardware::server::Service;
use rome_schema::robot::Device;
use rome_schema::{Params, Root};
use rome_sim_hardware::world::{SimBase, SimCamera, SimProximity, SimWorld};
use std::sync::{Mutex, OnceLock};
use std::time::Duration;

/// A decoder under test.
pub type Decoder = fn(&[u8]);

/// Every decoder, by name (the name of its fuzz target).
pub const ALL: &[(&str, Decoder)] = &[
    ("data_request", data_request),
    ("robot_command", robot_command),
    ("messages", messages),
    ("image_schema", image_schema),
    ("stickrep", stickrep),
    ("serial", serial),
];

/// (key, parameters, payload) from one input.
pub fn split(bytes: &[u8]) -> (String, String, Option<&[u8]>) {
    let mut parts = bytes.splitn(3, |b| *b == b'\n');
    let key = String::from_utf8_lossy(parts.next().unwrap_or_default()).into_owned();
    let params = String::from_utf8_lossy(parts.next().unwrap_or_default()).into_owned();
    (key, params, parts.next())
}

/// A data-server query: parsed, then applied to a store that lives
/// across inputs, so sequences of requests are tried too.
pub fn data_request(bytes: &[u8]) {
    static STORE: OnceLock<Mutex<rome_data::Store>> = OnceLock::new();
    let (key, params, payload) = split(bytes);
    let root = Root::default();
    let Ok(request) =
        rome_schema::data::request::Request::parse(&root, &key, Params::parse(&params), payload)
    else {
        return;
    };
    let store = STORE.get_or_init(|| {
        Mutex::new(rome_data::Store::new(4).with_limits(rome_data::Limits {
            max_variables: 1_000,
            max_semaphores: 1_000,
            max_bytes: 1 << 24,
        }))
    });
    let mut store = store.lock().unwrap_or_else(|p| p.into_inner());
    let _ = request.apply(&mut store, rome_clock::Instant::now());
}

struct Servers {
    base: Base<SimBase>,
    proximity: Proximity<SimProximity>,
    camera: Camera<SimCamera>,
}

fn device<T>(r: Result<T, rome_sim::SimError>) -> T {
    r.unwrap_or_else(|e| panic!("{e}"))
}

fn servers() -> &'static Servers {
    static SERVERS: OnceLock<Servers> = OnceLock::new();
    SERVERS.get_or_init(|| {
        let map = rome_maps::load_named("fig5_3").unwrap_or_else(|e| panic!("fig5_3: {e}"));
        let mut sim = rome_sim::Sim::new(&map, rome_sim::SimConfig::default());
        let at = sim.scene().world.positions.keys().next().cloned();
        let at = at.unwrap_or_else(|| panic!("fig5_3 has named positions"));
        sim.add_robot_at("r1", &at, 0.0)
            .unwrap_or_else(|e| panic!("{e}"));
        let world = SimWorld::new(sim);
        Servers {
            base: Base::new("r1", device(world.base("r1")), None),
            proximity: Proximity::new("r1", device(world.proximity("r1")), None),
            camera: Camera::new(
                "r1",
                "up",
                device(world.camera("r1", rome_sim::Camera::Up)),
                Duration::from_millis(500),
            ),
        }
    })
}

/// A hardware-server query: the key parsed, then the command of the
/// device it names (parse only: carrying it out would drive the robot).
pub fn robot_command(bytes: &[u8]) {
    let (key, params, payload) = split(bytes);
    let Ok(k) = Root::default().parse_robot(&key) else {
        return;
    };
    let mut params = Params::parse(&params);
    if rome_schema::robot::Meta::take(&mut params).is_err() {
        return;
    }
    let s = servers();
    match k.device {
        Device::Base => drop(s.base.parse(&k.command, params, payload)),
        Device::Proximity => drop(s.proximity.parse(&k.command, params, payload)),
        Device::Camera(_) => drop(s.camera.parse(&k.command, params, payload)),
    }
}

/// Every message a client or server decodes from the network.
pub fn messages(bytes: &[u8]) {
    use rome_schema::{data, decode, robot, sim, ErrorReply};
    macro_rules! each {
        ($($t:ty),* $(,)?) => { $( let _ = decode::<$t>(bytes, "fuzz"); )* };
    }
    each!(
        robot::Move,
        robot::Turn,
        robot::Go,
        robot::Jog,
        robot::Stop,
        robot::SetPose,
        robot::AdjustPose,
        robot::SetBumper,
        robot::Done,
        robot::PoseReply,
        robot::BumperReply,
        robot::SpeedReply,
        robot::WheelSpeedReply,
        robot::ModeReply,
        robot::LockGrant,
        robot::Unlocked,
        robot::CommandStats,
        robot::LockInfo,
        robot::LockRecord,
        robot::BaseState,
        robot::SonarReply,
        robot::IrReply,
        robot::SetTimeout,
        robot::TimeoutReply,
        robot::Scan,
        robot::SizeReply,
        robot::FrameInfo,
        data::SetReply,
        data::HistoryInfo,
        data::Committed,
        data::Rejected,
        data::SemState,
        data::CreateReply,
        data::SignalReply,
        data::TryWaitReply,
        data::WaitReply,
        sim::Truth,
        ErrorReply,
        rome_nav::board::Goal,
        rome_nav::board::Status,
        rome_nav::board::ActiveGoal,
        rome_nav::board::RouteInfo,
    );
}

/// An image reply's schema, and a row list.
pub fn image_schema(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    let _ = rome_schema::robot::Gray8::parse(&text);
    let _ = rome_schema::robot::parse_rows(&text, rome_schema::robot::MAX_ROWS);
}

/// A StickRep map file, and the geometry built from it when it loads.
pub fn stickrep(bytes: &[u8]) {
    let text = String::from_utf8_lossy(bytes);
    if let Ok(map) = rome_maps::parse("fuzz.stk", &text) {
        let world = rome_maps::World::from_map(&map);
        let _ = rome_maps::Network::new(&map, &world);
    }
}

/// Bytes from a Pioneer's serial line: framing, then the status packet.
pub fn serial(bytes: &[u8]) {
    use rome_hardware::serial::proto::{Deframer, Sip};
    let mut d = Deframer::default();
    for chunk in bytes.chunks(7) {
        d.push(chunk);
        while let Some(packet) = d.next_packet() {
            if let Ok(p) = packet {
                let _ = Sip::parse(&p);
            }
        }
    }
}

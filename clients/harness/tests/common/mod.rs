//! What the single-robot rig tests share: robot r1 at 350R on EB3 (or at
//! another start on another map), facing its route to 372L, the world
//! stepping, a planner's blackboard, and a Navigator and CTracker for it.

use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_harness::{Harness, RunConfig};
use rome_maps::{Network, World};
use rome_nav::board::{Board, Goal, GoalType, Sem};
use rome_nav::navigator::{NavConfig, Navigator};
use rome_nav::plan::Plan;

/// The rig, its stepping world, the heading of the route, and the
/// planner's blackboard with its semaphores declared.
// Each test binary compiles this module; not every one starts on EB3.
#[allow(dead_code)]
pub async fn one_robot(speed: f64) -> (Harness, rome_sim_hardware::world::Stepper, f64, Board) {
    one_robot_on("eb3", "350R", "372L", speed).await
}

/// As [`one_robot`], r1 at `from` on the built-in map `map`, facing its
/// route to `to`.
pub async fn one_robot_on(
    map: &str,
    from: &str,
    to: &str,
    speed: f64,
) -> (Harness, rome_sim_hardware::world::Stepper, f64, Board) {
    let map = rome_maps::load_named(map).expect("the map loads");
    let world_map = World::from_map(&map);
    let network = Network::new(&map, &world_map);
    let plan = Plan::new(&world_map, &network, from, to).expect("a plan");
    let heading = plan.start_heading_deg;
    let mut cfg = RunConfig::new(map, from, to);
    // These tests step the world themselves, against the wall clock.
    cfg.lockstep = false;
    cfg.speed = Some(speed);
    let starts = rome_harness::starts(&[("r1".to_string(), plan)]);
    let rig = Harness::start(&cfg, &starts, NetOptions::isolated())
        .await
        .expect("the rig starts");
    let stepper = rig.world.start(Some(speed));
    let planner = Board::new(
        DataClient::connect(&rig.session, DataOptions::new("planner"))
            .await
            .expect("planner data client"),
        "r1",
    );
    planner.declare().await.expect("semaphores");
    (rig, stepper, heading, planner)
}

/// A Navigator for r1 on data-client options `opts`, running until it ends.
pub async fn navigator(
    rig: &Harness,
    opts: DataOptions,
) -> tokio::task::JoinHandle<Result<(), rome_nav::NavError>> {
    let ds = DataClient::connect(&rig.session, opts)
        .await
        .expect("navigator data client");
    let robot = robot_client(rig, "navigator").await;
    let mut nav = Navigator::new(robot, Board::new(ds, "r1"), NavConfig::default());
    tokio::spawn(async move { nav.run().await })
}

/// A robot client of r1's for a test that reads the robot as `who` does.
pub async fn robot_client(rig: &Harness, who: &str) -> RobotClient {
    RobotClient::connect(&rig.session, "r1", RobotOptions::new(who))
        .await
        .unwrap_or_else(|e| panic!("{who}'s robot client: {e}"))
}

/// A CTracker for r1, running until it ends.
// Each test binary compiles this module; not every one starts a CTracker.
#[allow(dead_code)]
pub async fn ctracker(rig: &Harness) -> tokio::task::JoinHandle<Result<(), rome_nav::NavError>> {
    let ds = DataClient::connect(&rig.session, DataOptions::new("ctracker"))
        .await
        .expect("ctracker data client");
    let robot = robot_client(rig, "ctracker").await;
    let tracker = rome_nav::ctracker::CTracker::new(
        robot,
        Board::new(ds, "r1"),
        rome_nav::ctracker::TrackConfig::default(),
    );
    tokio::spawn(async move { tracker.run(None).await })
}

/// Hands the Navigator a D goal of `mm` along `heading` and waits, at most
/// `within`, until it says the goal is done.
pub async fn drive_d(planner: &Board, heading: f64, mm: i64, within: std::time::Duration) {
    planner
        .give_goal(&Goal {
            goal_type: GoalType::D,
            distance: mm,
            direction_deg: heading,
        })
        .await
        .expect("the goal is handed over");
    tokio::time::timeout(within, planner.down(Sem::RobotStatus))
        .await
        .expect("the Navigator carries out the D goal")
        .expect("the Planner hears it done");
}

/// Waits, checking every 20 ms, until `ok` holds (in ground truth, as the
/// tests' `rig.truth`) or `within` passes.
// Each test binary compiles this module; not every one waits on truth.
#[allow(dead_code)]
pub async fn until(within: std::time::Duration, mut ok: impl FnMut() -> bool) -> bool {
    let deadline = std::time::Instant::now() + within;
    while std::time::Instant::now() < deadline {
        if ok() {
            return true;
        }
        tokio::time::sleep(std::time::Duration::from_millis(20)).await;
    }
    ok()
}

/// Hands over an L goal of `lights` lights and waits until the robot has
/// driven half a metre.
#[allow(dead_code)]
pub async fn set_off_on_l(rig: &Harness, planner: &Board, heading: f64, lights: i64) {
    planner
        .give_goal(&Goal {
            goal_type: GoalType::L,
            distance: lights,
            direction_deg: heading,
        })
        .await
        .expect("the goal is handed over");
    let start = rig.truth(0);
    let moved = until(std::time::Duration::from_secs(20), || {
        let p = rig.truth(0);
        (p.at.x - start.at.x).hypot(p.at.y - start.at.y) > 500.0
    })
    .await;
    assert!(moved, "the robot never set off on its L goal");
}

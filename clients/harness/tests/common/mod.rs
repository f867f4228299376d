//! What the single-robot rig tests share: robot r1 at 350R on EB3, facing
//! its route to 372L, the world stepping, and a planner's blackboard.

use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions};
use rome_harness::{Harness, RunConfig};
use rome_maps::{Network, World};
use rome_nav::board::Board;
use rome_nav::plan::Plan;

/// The rig, its stepping world, the heading of the route, and the
/// planner's blackboard with its semaphores declared.
pub async fn one_robot(speed: f64) -> (Harness, rome_sim_hardware::world::Stepper, f64, Board) {
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let world_map = World::from_map(&map);
    let network = Network::new(&map, &world_map);
    let plan = Plan::new(&world_map, &network, "350R", "372L").expect("a plan");
    let heading = plan.start_heading_deg;
    let mut cfg = RunConfig::new(map, "350R", "372L");
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

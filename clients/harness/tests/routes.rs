//! Whole runs on the EB3 map, everything in one process (as `rome demo`):
//! fixed seeds, the default sensor noise and wheel slip, in lock-step, so
//! the machine's load does not change what the robot does. Each run must end
//! within a metre of its goal, having carried out every mode its plan
//! needs (the L / C / D columns of Tables 6.1–6.2).

use rome_harness::{self as run, RunConfig};
use rome_nav::report::Report;
use std::time::Duration;

async fn drive(from: &str, to: &str, seed: u64) -> Report {
    drive_with(from, to, seed, |_| {}).await
}

async fn drive_with(from: &str, to: &str, seed: u64, tweak: impl FnOnce(&mut RunConfig)) -> Report {
    rome_tests::show_warnings_on_failure();
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let mut cfg = RunConfig::new(map, from, to);
    cfg.seed = seed;
    tweak(&mut cfg);
    cfg.limit = Duration::from_secs(15 * 60);
    let report = run::run(cfg, |_| {}).await.expect("the run completes");
    println!(
        "{}\n{}\nmissed by {:.0} cm",
        report.table(),
        report.reasons().join("\n"),
        report.miss_cm
    );
    report
}

fn assert_arrived(r: &Report) {
    assert_eq!(r.failure, None, "{}", r.table());
    assert!(
        r.miss_cm < 100.0,
        "{} -> {} ended {:.0} cm from the goal\n{}",
        r.from,
        r.to,
        r.miss_cm,
        r.table()
    );
    assert_eq!(
        r.modes_done,
        r.modes_needed,
        "{}\n{}",
        r.table(),
        r.reasons().join("\n")
    );
    // The robot drove the route, not a shortcut or a detour.
    let planned = r.plan.route.length_mm / 1_000.0;
    assert!(
        (r.driven_m - planned).abs() < 0.05 * planned + 1.0,
        "drove {:.1} m of a {:.1} m route",
        r.driven_m,
        planned
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_straight_route_ends_within_a_metre_of_the_goal() {
    // Table 6.1, run 25: 350R to 372L, 59.74 m, L 1/1, D 1/1. Two child
    // trackers watch the same camera: the token lets only one report each
    // light, so the parent refuses nothing (a second report of a light
    // would come far too early and be refused).
    let r = drive_with("350R", "372L", 1, |cfg| {
        cfg.track.cameras = vec!["up".into(), "up".into()];
    })
    .await;
    assert_eq!(r.plan.route.turns, 0);
    assert_arrived(&r);
    let seen: usize = r.lights().map(|s| s.seen).sum();
    let refused: usize = r.lights().map(|s| s.refused).sum();
    assert!(
        seen + 2 >= r.plan.steps[0].goal.distance as usize,
        "lights seen: {seen}"
    );
    assert_eq!(refused, 0, "{:?}", r.lights().collect::<Vec<_>>());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn along_350r_to_376l_odometry_stays_within_30_cm_of_the_truth() {
    // The local mapper corrects the sideways offset as well as the heading,
    // and learns the drift; the monitor compares odometry with ground truth
    // every simulated second.
    let r = drive("350R", "376L", 1).await;
    assert_arrived(&r);
    let worst = r.odometry_max_error_cm.expect("odometry was watched");
    assert!(
        worst < 30.0,
        "odometry strayed {worst:.0} cm from the truth"
    );
    assert!(
        r.fixes.iter().any(|f| f.shift_mm != 0.0),
        "no sideways correction was made: {:?}",
        r.fixes
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_one_corner_route_ends_within_a_metre_of_the_goal() {
    // Table 6.2, run 1: 302L to A340R, 35.585 m, L 1/1, C 1/1, D 1/1.
    let r = drive("302L", "A340R", 2).await;
    assert_eq!(r.plan.route.turns, 1);
    assert_arrived(&r);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_multi_corner_route_ends_within_a_metre_of_the_goal() {
    // Down the new wing's corridor B, whose two lights are 22 m apart (the
    // kind of hallway Chapter 6 calls a trouble spot), and round two
    // corners.
    let r = drive("302L", "A351R", 3).await;
    assert_eq!(r.plan.route.turns, 2);
    assert_arrived(&r);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn one_seed_gives_the_same_run_to_the_last_bit() {
    // Two runs of one route and seed at once (each slowing the other, and
    // the other tests of this file running beside them): the same
    // trajectory point for point, the same table, the same corrections.
    let (a, b) = tokio::join!(drive("302L", "A340R", 7), drive("302L", "A340R", 7));
    assert_eq!(a.table(), b.table());
    assert_eq!(a.trail.len(), b.trail.len());
    let first = a
        .trail
        .iter()
        .zip(&b.trail)
        .position(|(p, q)| p.x.to_bits() != q.x.to_bits() || p.y.to_bits() != q.y.to_bits());
    assert_eq!(
        first,
        None,
        "the trajectories part at point {first:?} of {}: {:?} against {:?}",
        a.trail.len(),
        first.map(|i| a.trail[i]),
        first.map(|i| b.trail[i])
    );
    assert_eq!(a.miss_cm.to_bits(), b.miss_cm.to_bits());
    assert_eq!(a.run_time, b.run_time);
    assert_eq!(format!("{:?}", a.fixes), format!("{:?}", b.fixes));
    assert_eq!(format!("{:?}", a.plates), format!("{:?}", b.plates));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_that_cannot_move_is_given_up_as_stuck_with_its_position() {
    // The Navigator asks for no speed at all: the robot stays at the start
    // and the run is given up after the stuck time, not after the hour.
    // Before that, the Navigator says on its blackboard that it is
    // blocked, and by what.
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let mut cfg = RunConfig::new(map, "350R", "372L");
    cfg.nav.cruise_mm_s = 0.0;
    cfg.stuck = Duration::from_secs(40);
    let (tx, mut said) = tokio::sync::mpsc::unbounded_channel::<String>();
    let r = run::run(cfg, |e| {
        if let run::Event::Started { session } = e {
            let (session, tx) = (session.clone(), tx.clone());
            tokio::spawn(async move {
                let opts = rome_client::DataOptions::new("watch");
                let ds = rome_client::DataClient::connect(&session, opts).await?;
                let mut w = ds.watch("nav/r1/Status").await?;
                while let Some(Ok(c)) = w.next().await {
                    let why = c.value.as_ref().and_then(|v| v["blocked"].as_str());
                    if let Some(why) = why {
                        let _ = tx.send(why.to_string());
                    }
                }
                Ok::<(), rome_client::ClientError>(())
            });
        }
    })
    .await
    .expect("the run completes");
    let blocked = said
        .try_recv()
        .expect("the Navigator never said it was blocked");
    assert!(
        blocked.starts_with("blocked: something") && blocked.contains("no headway for 20 s"),
        "{blocked}"
    );
    let why = r.failure.as_deref().expect("the run is given up");
    assert!(why.contains("stuck at (111.0, 104.0) m"), "{why}");
    assert!(r.run_time < Duration::from_secs(60), "{:?}", r.run_time);
    assert!(r.driven_m < 0.5, "{}", r.driven_m);
    assert_eq!(r.modes_done.d, 0, "{}", r.table());
    assert!(r.miss_cm > 5_000.0);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_bad_light_count_ends_the_run_with_the_navigators_reason() {
    // While the robot counts the lights of its first L segment, someone
    // keeps writing a JSON object where the count should be. The Navigator
    // ends that goal and says why; the Planner ends the run there with the
    // reason, and the robot does not drive on.
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let cfg = RunConfig::new(map, "350R", "372L");
    let mut session = None;
    let mut writing = None;
    let r = run::run(cfg, |e| match e {
        run::Event::Started { session: s } => session = Some(s.clone()),
        run::Event::Goal { handed, .. }
            if handed.step.goal.goal_type == rome_nav::board::GoalType::L && writing.is_none() =>
        {
            let s = session.clone().expect("the run's session");
            writing = Some(tokio::spawn(async move {
                let opts = rome_client::DataOptions::new("meddler");
                let ds = rome_client::DataClient::connect(&s, opts)
                    .await
                    .expect("the meddler's data client");
                let bad = serde_json::json!({"lights": "many"});
                // Again and again: the CTracker writes its counts between.
                while ds.set("nav/r1/CeilingLight", &bad).await.is_ok() {
                    tokio::time::sleep(Duration::from_millis(50)).await;
                }
            }));
        }
        _ => {}
    })
    .await
    .expect("the run completes");
    if let Some(w) = writing {
        w.abort();
    }
    let ended: Vec<_> = r
        .steps
        .iter()
        .filter_map(|h| h.failure.as_deref())
        .collect();
    let why = ended.last().expect("a goal failed");
    assert!(
        why.contains("CeilingLight") && why.contains("invalid type: map"),
        "{why}"
    );
    assert!(!r.arrived(), "{}", r.table());
    assert!(r.steps.len() < r.plan.steps.len(), "{}", r.table());
}

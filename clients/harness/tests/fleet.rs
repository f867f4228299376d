//! Several robots at once through one data server, in one process, judged
//! by ground truth: robots that meet head-on (in a wide corridor, a
//! narrow one, and on the way to a corner) or catch up with each other,
//! a robot leaving a corner as another comes along the corridor,
//! robots taking turns through a narrow passage or a lane, and a run
//! whose mode is made to fail and is reported failed.

use rome_harness::{self as run, Event, FleetReport, PartState, RouteSpec, RunConfig};
use rome_nav::report::Report;
use std::time::Duration;

fn eb3() -> rome_maps::Map {
    rome_maps::load_named("eb3").expect("eb3 loads")
}

/// r1 from `one.0` to `one.1` and r2 from `two.0` to `two.1` on EB3.
fn two_on_eb3(one: (&str, &str), two: (&str, &str)) -> RunConfig {
    RunConfig::fleet(
        eb3(),
        vec![
            RouteSpec::new("r1", one.0, one.1),
            RouteSpec::new("r2", two.0, two.1),
        ],
    )
}

async fn fleet(cfg: RunConfig, mut on: impl FnMut(&Event)) -> FleetReport {
    rome_tests::show_warnings_on_failure();
    let mut cfg = cfg;
    cfg.limit = Duration::from_secs(20 * 60);
    let report = run::run_fleet(cfg, &mut |e| on(&e))
        .await
        .expect("the run completes");
    println!("{}", report.table());
    for why in report.reasons() {
        println!("{why}");
    }
    report
}

fn assert_clean(r: &Report) {
    assert!(
        r.arrived(),
        "{} ended {:.0} cm from {}: {:?}\n{}",
        r.robot,
        r.miss_cm,
        r.to,
        r.failure,
        r.table()
    );
    assert_eq!(r.modes_done, r.modes_needed, "{}", r.table());
    assert_eq!(r.contacts.total(), 0, "{}: {:?}", r.robot, r.contacts);
    // Corners are driven on odometry alone until the next corridor's walls
    // correct it: a metre is the sanity bound here; the straight run's
    // 0.3 m is checked in routes.rs.
    assert!(
        r.odometry_max_error_cm.unwrap_or(f64::MAX) < 100.0,
        "{}: odometry strayed {:?} cm from the truth",
        r.robot,
        r.odometry_max_error_cm
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_robots_meeting_head_on_in_one_corridor_both_arrive() {
    // Both in corridor A, r1 westwards and r2 eastwards: they pass each
    // other half-way, each seeing the other on sonar.
    let cfg = two_on_eb3(("356R", "372L"), ("371R", "353L"));
    let mut closest = f64::MAX;
    let r = fleet(cfg, |e| {
        if let Event::Tick { robots, .. } = e {
            let (a, b) = (robots[0].pose, robots[1].pose);
            closest = closest.min((a.at.x - b.at.x).hypot(a.at.y - b.at.y));
        }
    })
    .await;
    for robot in &r.robots {
        assert_clean(robot);
    }
    // They really met: closer than two robot lengths at some moment.
    assert!(closest < 2_000.0, "closest approach {closest:.0} mm");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_catching_up_with_a_slower_one_arrives_and_so_does_the_slow_one() {
    // r2 starts 16.5 m ahead of r1 in corridor A and drives at half r1's
    // speed: r1 catches up with it a third of the way along and must get
    // past to reach its goal beyond r2's.
    let mut slow = RouteSpec::new("r2", "356R", "372L");
    slow.cruise_mm_s = Some(200.0);
    let cfg = RunConfig::fleet(eb3(), vec![RouteSpec::new("r1", "350R", "376L"), slow]);
    let mut behind_then_level = (false, false);
    let r = fleet(cfg, |e| {
        if let Event::Tick { robots, .. } = e {
            // Westwards: r1 behind r2 means a larger x.
            let gap = robots[0].pose.at.x - robots[1].pose.at.x;
            behind_then_level.0 |= gap > 5_000.0;
            behind_then_level.1 |= behind_then_level.0 && gap < 1_500.0;
        }
    })
    .await;
    for robot in &r.robots {
        assert_clean(robot);
    }
    assert!(
        behind_then_level.0 && behind_then_level.1,
        "r1 never caught up with r2"
    );
}

/// EB3 with corridor N (the new wing's middle corridor, x = 60 m between
/// rings B and C) marked as a narrow passage.
fn eb3_with_passage() -> rome_maps::Map {
    rome_tests::with_corridor_n_passage(eb3())
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn robots_take_turns_through_a_narrow_passage() {
    // r1 goes south through corridor N and r2 north: head-on in a corridor
    // too narrow to pass. One waits outside while the other goes through.
    let cfg = RunConfig::fleet(
        eb3_with_passage(),
        vec![
            RouteSpec::new("r1", "303R", "A352L"),
            RouteSpec::new("r2", "A353R", "301L"),
        ],
    );
    let in_n = |p: &rome_sim::Pose| {
        (p.at.x - 60_000.0).abs() < 1_300.0 && p.at.y > 9_000.0 && p.at.y < 53_000.0
    };
    let (mut both_inside, mut waited) = (0, Vec::new());
    let r = fleet(cfg, |e| match e {
        Event::Tick { robots, .. } if in_n(&robots[0].pose) && in_n(&robots[1].pose) => {
            both_inside += 1;
        }
        Event::Traffic {
            robot,
            part,
            state: PartState::Waiting,
        } if part == "$passage/N" => waited.push(*robot),
        _ => {}
    })
    .await;
    for robot in &r.robots {
        assert_eq!(robot.plan.passages.len(), 1, "{}", robot.robot);
        assert_clean(robot);
    }
    assert_eq!(both_inside, 0, "both robots were in corridor N at once");
    assert_eq!(waited.len(), 1, "exactly one robot waited: {waited:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_lanes_robots_drive_a_narrow_corridor_one_way_at_a_time() {
    // The same two robots head on through corridor N, which is now only
    // as narrow as it is (2.44 m): with lanes one waits outside until the
    // other has left. Without them they meet inside (the test below).
    let mut cfg = two_on_eb3(("303R", "A352L"), ("A353R", "301L"));
    cfg.rules.lanes = true;
    let (mut both_inside, mut waited) = (0, Vec::new());
    let r = fleet(cfg, |e| match e {
        Event::Tick { robots, .. }
            if in_corridor_n(&robots[0].pose) && in_corridor_n(&robots[1].pose) =>
        {
            both_inside += 1;
        }
        Event::Traffic {
            robot,
            part,
            state: PartState::Waiting,
        } if part.starts_with(rome_nav::traffic::lanes::LANE_PREFIX) => waited.push(*robot),
        _ => {}
    })
    .await;
    for robot in &r.robots {
        let lanes: Vec<&str> = (robot.plan.holds.iter())
            .map(|h| h.semaphore.as_str())
            .filter(|s| s.starts_with(rome_nav::traffic::lanes::LANE_PREFIX))
            .collect();
        assert!(lanes.len() >= 2, "{}: {lanes:?}", robot.robot);
        assert_clean(robot);
    }
    assert_eq!(both_inside, 0, "both robots were in corridor N at once");
    assert_eq!(waited.len(), 1, "exactly one robot waited: {waited:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn with_one_way_corridors_nobody_drives_corridor_n_north_and_both_arrive() {
    // The same two robots: r2's shortest way to 301L is north up N. With
    // the new wing's narrow corridors one way (N is south), it goes round
    // by another corridor, and they never meet head on.
    let mut cfg = two_on_eb3(("303R", "A352L"), ("A353R", "301L"));
    cfg.rules.one_way = true;
    let (mut north, mut last_y) = (0, [None::<f64>; 2]);
    let r = fleet(cfg, |e| {
        if let Event::Tick { robots, .. } = e {
            for (k, robot) in robots.iter().take(2).enumerate() {
                let y = robot.pose.at.y;
                if in_corridor_n(&robot.pose) && last_y[k].is_some_and(|before| y > before + 5.0) {
                    north += 1;
                }
                last_y[k] = Some(y);
            }
        }
    })
    .await;
    for robot in &r.robots {
        assert_clean(robot);
    }
    assert_eq!(north, 0, "ticks with a robot driving north in corridor N");
    // The shortest way, which the one-way network refused, is up N.
    let map = eb3();
    let world = rome_maps::World::from_map(&map);
    let plain = rome_maps::Network::new(&map, &world);
    let short = world.route(&plain, "A353R", &[], "301L").expect("a route");
    let taken = &r.robots[1].plan.route;
    assert!(
        taken.length_mm > short.length_mm + 10_000.0,
        "r2 went {:.1} m, the shortest way is {:.1} m",
        taken.length_mm / 1000.0,
        short.length_mm / 1000.0
    );
    let up_n = |w: &[rome_maps::geometry::Point]| {
        (w[0].x - 60_000.0).abs() < 1_300.0
            && (w[1].x - 60_000.0).abs() < 1_300.0
            && w[1].y > w[0].y + 10_000.0
    };
    assert!(short.points.windows(2).any(up_n), "{:?}", short.points);
    assert!(!taken.points.windows(2).any(up_n), "{:?}", taken.points);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_whose_camera_is_covered_has_its_light_segment_failed_with_the_reason() {
    let mut cfg = RunConfig::fleet(eb3(), vec![RouteSpec::new("r1", "350R", "372L")]);
    cfg.covered = vec!["r1".into()];
    let r = fleet(cfg, |_| {}).await;
    let r = &r.robots[0];
    assert_eq!(r.modes_needed.l, 1);
    assert_eq!(r.modes_done.l, 0, "{}", r.table());
    assert!(r.row(1).contains("0/1*"), "{}", r.row(1));
    let reasons = r.reasons().join("\n");
    assert!(
        reasons.contains("L (goal 1") && reasons.contains("missed"),
        "{reasons}"
    );
    // The same route with the camera uncovered is not starred.
    let cfg = RunConfig::fleet(eb3(), vec![RouteSpec::new("r1", "350R", "372L")]);
    let ok = fleet(cfg, |_| {}).await;
    assert_eq!(ok.robots[0].modes_done.l, 1, "{}", ok.table());
    assert!(!ok.robots[0].row(1).contains('*'), "{}", ok.table());
}

/// Whether a pose is in corridor N (x = 60 m, between the old building's
/// south corridor and the new wing's south one).
fn in_corridor_n(p: &rome_sim::Pose) -> bool {
    (p.at.x - 60_000.0).abs() < 1_300.0 && p.at.y > 9_000.0 && p.at.y < 53_000.0
}

/// Where two robots passed in corridor N.
struct Passed {
    /// How close they came while both were in N, mm.
    apart: f64,
    /// r1's and r2's x then, mm (N's middle is x = 60 m).
    x: (f64, f64),
}

/// Runs r1 from `one` and r2 from `two` on EB3; the report, and where
/// they came closest in corridor N.
async fn through_corridor_n(one: (&str, &str), two: (&str, &str)) -> (FleetReport, Passed) {
    let cfg = two_on_eb3(one, two);
    let mut closest = Passed {
        apart: f64::MAX,
        x: (0.0, 0.0),
    };
    let r = fleet(cfg, |e| {
        if let Event::Tick { robots, .. } = e {
            let (a, b) = (robots[0].pose, robots[1].pose);
            let apart = (a.at.x - b.at.x).hypot(a.at.y - b.at.y);
            if in_corridor_n(&a) && in_corridor_n(&b) && apart < closest.apart {
                closest = Passed {
                    apart,
                    x: (a.at.x, b.at.x),
                };
            }
        }
    })
    .await;
    (r, closest)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_robots_head_on_in_a_narrow_corridor_pass_without_touching() {
    // Corridor N is 2.44 m wide: two robots of 0.76 m pass only if both
    // are well over to their right by the time they meet. Steering over
    // at the hallway's gentle rate, each touched a wall as they passed.
    let (r, passed) = through_corridor_n(("303R", "A352L"), ("A353R", "301L")).await;
    for robot in &r.robots {
        assert_clean(robot);
    }
    // They met inside it: a second apart at their speeds is 0.8 m of
    // closing, so some tick has them within a few metres.
    assert!(
        passed.apart < 3_000.0,
        "closest approach in N {:.0} mm",
        passed.apart
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn two_robots_head_on_where_one_drives_to_a_corner_pass_without_touching() {
    // r2 drives up corridor N to its corner with corridor M: a light, then
    // one Enter-Corner goal of 15.5 m, in the Corner state. r1 comes round
    // that corner and down N. They meet with r2 some metres short of the
    // turning space. Both must keep right, the one heading for the corner
    // too: in the Corner state alone r2 stayed on the middle until its
    // infrared saw r1, and the two stood nose to nose for 12 s.
    let (r, passed) = through_corridor_n(("305R", "A338L"), ("A336L", "301L")).await;
    for robot in &r.robots {
        // Not `assert_clean`: r1's odometry strays up to 1.3 m between
        // the turn into N and its first light there, met or not.
        assert!(robot.arrived(), "{}", robot.table());
        assert_eq!(robot.modes_done, robot.modes_needed, "{}", robot.table());
        assert_eq!(
            robot.contacts.total(),
            0,
            "{}: {:?}",
            robot.robot,
            robot.contacts
        );
    }
    let (apart, (r1_x, r2_x)) = (passed.apart, passed.x);
    assert!(apart < 3_000.0, "closest approach in N {apart:.0} mm");
    // N's middle is x = 60 m. r1 drives south, its right is west; r2
    // north, its right is east.
    assert!(
        r1_x < 59_700.0 && r2_x > 60_300.0,
        "at the closest approach ({apart:.0} mm) r1 was {:.0} mm and r2 {:.0} mm right of the middle",
        60_000.0 - r1_x,
        r2_x - 60_000.0
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_leaving_a_corner_keeps_right_for_one_coming_along_the_corridor() {
    // r1 comes down corridor N and turns east into P (a Leave-Corner goal
    // of 1.8 m), as r2 comes west along P past N's mouth. In the Corner
    // state alone, r1's infrared saw r2 ahead and it spun away from it
    // until clear, round to facing west; it drove on that way, 49 m from
    // its goal, touching r2 on the way. Keeping right as in a hallway, it
    // leaves the turning space with r2 passing on its left. (Off by
    // default: at forty robots it made more contacts, docs/traffic.md.)
    let mut cfg = two_on_eb3(("A332L", "A353L"), ("A357R", "A352L"));
    cfg.nav.leave_corner_keep_right = true;
    let r = fleet(cfg, |_| {}).await;
    for robot in &r.robots {
        assert_clean(robot);
    }
}

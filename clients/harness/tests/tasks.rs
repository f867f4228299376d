//! A fleet given tasks through the dispatcher, in lock-step, judged by
//! ground truth: each task goes to the nearest free robot and is done
//! there; a task pinned to a robot waits for it; a task for nowhere fails
//! with the reason; a task whose robot's crew dies goes to another robot
//! and says why; a robot between tasks steps aside for the others; tasks
//! that come as a stream are added when they come.

use rome_harness::tasks::{run_tasks, Said, TaskEvent, TaskReport, TaskRun};
use rome_harness::{RouteSpec, RunConfig};
use rome_nav::fleet::schema::{TaskSpec, TaskState, TaskStatus};
use std::time::Duration;

fn spec(to: &str, robot: Option<&str>) -> TaskSpec {
    TaskSpec {
        to: to.into(),
        robot: robot.map(Into::into),
        priority: 0,
        via: vec![],
    }
}

/// Tasks each pinned to a robot: (id, to, robot).
fn pinned<'a>(tasks: &[(&'a str, &str, &str)]) -> Vec<(&'a str, TaskSpec)> {
    tasks
        .iter()
        .map(|(id, to, robot)| (*id, spec(to, Some(robot))))
        .collect()
}

async fn run(
    robots: &[(&str, &str)],
    tasks: Vec<(&str, TaskSpec)>,
    kill: Option<&str>,
) -> TaskReport {
    run_with(robots, tasks, kill, |_| {}).await
}

async fn run_with(
    robots: &[(&str, &str)],
    tasks: Vec<(&str, TaskSpec)>,
    kill: Option<&str>,
    adjust: impl FnOnce(&mut TaskRun),
) -> TaskReport {
    run_said(robots, tasks, kill, adjust, &mut Vec::new()).await
}

/// [`run_with`], keeping what each robot said in `said`.
async fn run_said(
    robots: &[(&str, &str)],
    tasks: Vec<(&str, TaskSpec)>,
    kill: Option<&str>,
    adjust: impl FnOnce(&mut TaskRun),
    said: &mut Vec<(String, Said)>,
) -> TaskReport {
    rome_tests::show_warnings_on_failure();
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let routes = robots
        .iter()
        .map(|(r, at)| RouteSpec::new(r, at, at))
        .collect();
    let mut cfg = RunConfig::fleet(map, routes);
    cfg.limit = Duration::from_secs(15 * 60);
    cfg.plfinder = false;
    let mut run = TaskRun {
        run: cfg,
        tasks: tasks
            .into_iter()
            .map(|(id, s)| (id.to_string(), s))
            .collect(),
        every: None,
        kill: kill.map(Into::into),
        closed: None,
        stay: Vec::new(),
    };
    adjust(&mut run);
    let report = run_tasks(run, &mut |e| match e {
        TaskEvent::Task(s, what) => println!("{} ({}): {what}", s.id, s.to),
        TaskEvent::Robot(r, s) => {
            println!("{r}: {s}");
            said.push((r, s));
        }
    })
    .await
    .expect("the run completes");
    println!(
        "{:.0} s simulated in {:.1?}; contacts {:?}; longest still {:?}",
        report.sim_s, report.wall, report.contacts, report.longest_still_s
    );
    report
}

fn all_done(r: &TaskReport, ids: &[&str]) {
    for id in ids {
        let t = status(r, id);
        assert_eq!(t.state, TaskState::Done, "{t:?}");
    }
}

/// No robot touched a wall or another robot, by ground truth.
fn untouched(r: &TaskReport) {
    for (robot, c) in &r.contacts {
        assert_eq!((c.wall, c.robot), (0, 0), "{robot} touched: {c:?}");
    }
}

fn status<'a>(r: &'a TaskReport, id: &str) -> &'a TaskStatus {
    r.statuses
        .iter()
        .find(|s| s.id == id)
        .unwrap_or_else(|| panic!("no status for {id}: {:?}", r.statuses))
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tasks_go_to_the_nearest_free_robot_and_are_done_where_ground_truth_says() {
    let r = run(
        &[("r1", "350R"), ("r2", "376L")],
        vec![
            ("T1", spec("356R", None)),
            ("T2", spec("372L", None)),
            ("T3", spec("352L", Some("r1"))),
            ("T4", spec("nowhere", None)),
        ],
        None,
    )
    .await;
    for (id, robot) in [("T1", "r1"), ("T2", "r2"), ("T3", "r1")] {
        let s = status(&r, id);
        assert_eq!(s.state, TaskState::Done, "{s:?}");
        assert_eq!(s.tried, vec![robot.to_string()], "{s:?}");
    }
    let t3 = status(&r, "T3");
    let t1 = status(&r, "T1");
    assert!(
        t3.assigned_ms >= t1.ended_ms,
        "the pinned task waited for its robot: {t1:?} {t3:?}"
    );
    let t4 = status(&r, "T4");
    assert_eq!(t4.state, TaskState::Failed);
    assert!(t4.why[0].contains("no position 'nowhere'"), "{t4:?}");
    for (robot, c) in &r.contacts {
        assert_eq!(c.wall + c.robot, 0, "{robot} touched something: {c:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_task_whose_robot_dies_goes_to_another_and_says_why() {
    // r2 at 360L is nearer 356R (11 m) than r1 at 350R (16 m): it takes
    // the task, and its whole crew dies at that moment.
    let r = run(
        &[("r1", "350R"), ("r2", "360L")],
        vec![("T1", spec("356R", None))],
        Some("r2"),
    )
    .await;
    let s = status(&r, "T1");
    assert_eq!(s.state, TaskState::Done, "{s:?}");
    assert_eq!(s.tried, vec!["r2".to_string(), "r1".to_string()], "{s:?}");
    assert!(
        s.why[0].contains("r2's Planner is gone"),
        "the task says why it moved: {s:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_task_that_takes_far_too_long_is_given_up_as_overdue_and_the_robot_goes_on() {
    // Every task is allowed only its two minutes' grace, and the 78 m to
    // 376L take longer. A robot that drives on without arriving is never
    // blocked, and without a deadline its task never ended.
    let r = run_with(
        &[("r1", "350R")],
        pinned(&[("T1", "376L", "r1"), ("T2", "352L", "r1")]),
        None,
        |t| t.run.slowest_mm_s = 1e9,
    )
    .await;
    let t1 = status(&r, "T1");
    assert_eq!(t1.state, TaskState::Failed, "{t1:?}");
    assert!(
        t1.why.iter().any(|w| w.contains("overdue at (")),
        "the task says it was overdue, and where: {t1:?}"
    );
    // Once overdue, the robot stays in service and takes the next task,
    // and does it: its Navigator left T1's goal when T1 was given up
    // rather than driving on to it.
    let t2 = status(&r, "T2");
    assert_eq!(t2.tried, vec!["r1".to_string()], "{t2:?}");
    assert!(t2.assigned_ms >= t1.ended_ms, "{t1:?} {t2:?}");
    assert_eq!(t2.state, TaskState::Done, "{t2:?}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_between_tasks_steps_aside_and_another_passes_it_in_a_narrow_corridor() {
    // r1 drives south down corridor N (2.44 m wide, x = 60 m) to A336L and
    // has no other task; r2 comes the long way round from corridor M and
    // passes that spot on its way to A342R. On the corridor's middle r1
    // leaves 0.84 m either side of it, and r2 is 0.76 m wide.
    let r = run(
        &[("r1", "A326L"), ("r2", "309R")],
        pinned(&[("T1", "A336L", "r1"), ("T2", "A342R", "r2")]),
        None,
    )
    .await;
    all_done(&r, &["T1", "T2"]);
    // Heading south, right is west: r1 stands by the west wall, not on the
    // middle line, by ground truth.
    let (x, _) = r.at_end["r1"];
    assert!(
        x < 60_000.0 - 500.0,
        "r1 stands at x = {:.2} m, the corridor's middle is 60 m",
        x / 1000.0
    );
    untouched(&r);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_whose_task_ends_beside_one_waiting_drives_on_to_stand_apart() {
    // r2 waits at A336L from the start, stepped aside in corridor N. r1
    // comes down N to A336R, the other jamb of the same door, 0.9 m on:
    // the two waiting there would leave no way between them. r3 comes the
    // long way round to A342R, down N past that door, and keeps the run
    // going until r1 has waited.
    let mut said = Vec::new();
    let r = run_said(
        &[("r1", "A326L"), ("r2", "A336L"), ("r3", "309R")],
        pinned(&[("T1", "A336R", "r1"), ("T3", "A342R", "r3")]),
        None,
        |_| {},
        &mut said,
    )
    .await;
    all_done(&r, &["T1", "T3"]);
    untouched(&r);
    let apart: Vec<_> = (said.iter())
        .filter(|(robot, s)| robot == "r1" && matches!(s, Said::Apart(Ok(_))))
        .collect();
    assert!(!apart.is_empty(), "r1 never drove on: {said:?}");
    // By ground truth the two stand apart at the end.
    let ((x1, y1), (x2, y2)) = (r.at_end["r1"], r.at_end["r2"]);
    let apart_mm = (x1 - x2).hypot(y1 - y2);
    assert!(
        apart_mm >= rome_nav::fleet::way::WAY_APART_MM,
        "r1 and r2 end {:.2} m apart",
        apart_mm / 1000.0
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_held_up_by_one_standing_idle_asks_it_to_make_way() {
    // As in the test above, r1 drives down corridor N to A336L and has no
    // other task, and r2 comes the long way round to A342R, past that
    // spot; but r1 does not step aside (a step aside cut short): it stands
    // on the middle, 0.84 m either side of it for r2's 0.76 m.
    let mut said = Vec::new();
    let r = run_said(
        &[("r1", "A326L"), ("r2", "309R")],
        pinned(&[("T1", "A336L", "r1"), ("T2", "A342R", "r2")]),
        None,
        |t| {
            t.stay = vec!["r1".into()];
            t.run.rules.make_way = true;
        },
        &mut said,
    )
    .await;
    all_done(&r, &["T1", "T2"]);
    untouched(&r);
    assert_eq!(status(&r, "T2").tried, vec!["r2".to_string()]);
    let made: Vec<_> = (said.iter())
        .filter(|(robot, s)| robot == "r1" && matches!(s, Said::MadeWay(by, Ok(_)) if by == "r2"))
        .collect();
    assert!(!made.is_empty(), "r1 never made way for r2: {said:?}");
    // By ground truth r1 ends further south than A336L: it drove on the
    // way r2 went, down N.
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let world = rome_maps::World::from_map(&map);
    let a336l = world.position("A336L").expect("A336L").in_corridor();
    let (_, y) = r.at_end["r1"];
    assert!(
        y < a336l.y - 2_000.0,
        "r1 ends at y = {:.2} m, A336L is at {:.2} m",
        y / 1000.0,
        a336l.y / 1000.0
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_blocked_by_one_standing_idle_stands_before_it_and_gives_its_task_up() {
    // As above, r1 stands on N's middle at A336L and r2 comes the long way
    // round to A342R past it, but nobody is asked to make way. Blocked,
    // r2 stands before r1 while the way stays closed, untouched, and gives
    // its task up saying why.
    let r = run_with(
        &[("r1", "A326L"), ("r2", "309R")],
        pinned(&[("T1", "A336L", "r1"), ("T2", "A342R", "r2")]),
        None,
        |t| {
            t.stay = vec!["r1".into()];
            t.run.nav.stand_when_blocked = true;
        },
    )
    .await;
    assert_eq!(status(&r, "T1").state, TaskState::Done);
    untouched(&r);
    let t2 = status(&r, "T2");
    assert_eq!(t2.state, TaskState::Failed, "{t2:?}");
    assert!(
        t2.why.iter().any(|w| w.contains("the Navigator: blocked")),
        "{t2:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_that_ended_its_task_in_a_junction_drives_out_of_it_and_steps_aside() {
    // A392R lies in the T-junction at corridor N's foot (x = 60 m), where
    // N, one way south, meets P (y = 6.5 m): no walls beside it to step
    // aside to. r1 drives straight down N and ends its task there, facing
    // P's south wall; r2 comes the long way round, down N to A342R.
    let r = run_with(
        &[("r1", "A342R"), ("r2", "309R")],
        pinned(&[("T1", "A392R", "r1"), ("T2", "A342R", "r2")]),
        None,
        |t| {
            t.run.rules.one_way = true;
            t.run.rules.leave_open = true;
        },
    )
    .await;
    all_done(&r, &["T1", "T2"]);
    // By ground truth, r1 left the junction (N's walls at x = 58.78 and
    // 61.22 m, and its body's radius) and stands by one of P's walls.
    let (x, y) = r.at_end["r1"];
    assert!(
        (x - 60_000.0).abs() > 1_220.0 + 380.0,
        "r1 stands at ({:.2}, {:.2}) m, in the junction",
        x / 1000.0,
        y / 1000.0
    );
    assert!(
        (y - 6_500.0).abs() > 500.0,
        "r1 stands at ({:.2}, {:.2}) m, on P's middle",
        x / 1000.0,
        y / 1000.0
    );
    untouched(&r);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_robot_out_of_a_junction_keeps_clear_of_the_first() {
    // Both ends of A392 lie in the T-junction at N's foot. r1 comes 8 m
    // down N to A392R and drives out first; r2 comes 23 m down N to A392L
    // soon after. The first way out from there ends where r1 now stands:
    // taken again, r2 drives into r1. r3 comes the long way round to
    // A342R, so the run lasts until both have stepped aside.
    let r = run_with(
        &[("r1", "A342R"), ("r2", "A336L"), ("r3", "309R")],
        pinned(&[
            ("T1", "A392R", "r1"),
            ("T2", "A392L", "r2"),
            ("T3", "A342R", "r3"),
        ]),
        None,
        |t| {
            t.run.rules.one_way = true;
            t.run.rules.leave_open = true;
        },
    )
    .await;
    all_done(&r, &["T1", "T2", "T3"]);
    untouched(&r);
    let ((x1, y1), (x2, y2)) = (r.at_end["r1"], r.at_end["r2"]);
    for (name, x) in [("r1", x1), ("r2", x2)] {
        assert!(
            (x - 60_000.0).abs() > 1_220.0 + 380.0,
            "{name} stands at x = {:.2} m, in the junction",
            x / 1000.0
        );
    }
    // By ground truth, apart by more than two bodies and a passing lane.
    let apart = (x1 - x2).hypot(y1 - y2);
    assert!(apart > 1_200.0, "r1 and r2 stand {apart:.0} mm apart");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_that_stood_aside_sets_off_from_where_it_stands() {
    // r1 waits at 302L in the 3.66 m hall M, just west of N's mouth, and
    // steps 1.3 m over to the hall's south wall. Its task then takes it
    // down N. Planned from 302L's point on the hall's middle, the first
    // leg runs straight down N; driven from 1.3 m south of that point, it
    // runs on a slant into the end of N's west wall.
    let r = run_with(
        &[("r1", "302L"), ("r2", "309R")],
        pinned(&[("T1", "A342R", "r2"), ("T2", "A326L", "r1")]),
        None,
        |t| t.every = Some(Duration::from_secs(20)),
    )
    .await;
    all_done(&r, &["T1", "T2"]);
    untouched(&r);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_waiting_for_its_first_task_steps_aside_and_another_passes_it() {
    // r1 starts at A336L in corridor N and is given nothing; r2 comes the
    // long way round and passes it on its way to A342R. Left on the
    // middle, r1 is touched.
    let r = run(
        &[("r1", "A336L"), ("r2", "309R")],
        pinned(&[("T2", "A342R", "r2")]),
        None,
    )
    .await;
    all_done(&r, &["T2"]);
    let (x, _) = r.at_end["r1"];
    assert!(
        (x - 60_000.0).abs() > 500.0,
        "r1 stands at x = {:.2} m, the corridor's middle is 60 m",
        x / 1000.0
    );
    untouched(&r);
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_waiting_its_turn_for_a_narrow_passage_is_not_blocked() {
    // Corridor N is a narrow passage, and r1 and r2 meet head-on there:
    // one waits outside the whole time the other takes to drive its 44 m,
    // far longer than the 20 s a robot may stand still before it is
    // blocked. Counted as standing still, the wait failed its task.
    let r = run_with(
        &[("r1", "303R"), ("r2", "A353R")],
        pinned(&[("T1", "A352L", "r1"), ("T2", "301L", "r2")]),
        None,
        |t| {
            t.run.map = rome_tests::with_corridor_n_passage(t.run.map.clone());
            t.run.stuck = Duration::from_secs(20);
        },
    )
    .await;
    let waited = r.traffic_wait_s.values().fold(0.0_f64, |a, b| a.max(*b));
    assert!(
        waited > 40.0,
        "one robot waited its turn longer than it may stand still: {:?}",
        r.traffic_wait_s
    );
    for (id, robot) in [("T1", "r1"), ("T2", "r2")] {
        let t = status(&r, id);
        assert_eq!(t.state, TaskState::Done, "{t:?}");
        assert_eq!(t.tried, vec![robot.to_string()], "{t:?}");
        assert!(t.why.is_empty(), "{t:?}");
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_blocked_twice_in_one_place_rests_gets_clear_and_takes_tasks_again() {
    // Three people stand across corridor N (2.44 m wide) halfway from
    // A326L to A336L for the first 150 s, and a robot may stand still for
    // 20 s. r1, sent through them twice, is blocked twice in one place and
    // goes out of service. Out of service for good, it never took T3.
    let map = rome_maps::load_named("eb3").expect("eb3 loads");
    let world = rome_maps::World::from_map(&map);
    let at = |p: &str| world.position(p).expect("on the map").in_corridor();
    let (a, b) = (at("A326L"), at("A336L"));
    let along = (b - a).normalize();
    let across = rome_maps::geometry::Vector::new(-along.y, along.x);
    let middle = a + (b - a) * 0.5;
    let people = [-800.0, 0.0, 800.0].map(|k| middle + across * k).to_vec();
    let r = run_with(
        &[("r1", "A326L")],
        pinned(&[
            ("T1", "A336L", "r1"),
            ("T2", "A336L", "r1"),
            ("T3", "A336L", "r1"),
        ]),
        None,
        |t| {
            t.run.stuck = Duration::from_secs(20);
            t.closed = Some((people, Duration::from_secs(150)));
        },
    )
    .await;
    for id in ["T1", "T2"] {
        let t = status(&r, id);
        assert_eq!(t.state, TaskState::Failed, "{t:?}");
        assert!(t.why.iter().any(|w| w.contains("blocked at (")), "{t:?}");
    }
    // Where it stood longest with a task: before the people, on T1 or T2.
    let still = &r.longest_still_at["r1"];
    assert_eq!(still.still_s, r.longest_still_s["r1"], "{still:?}");
    assert!(still.still_s > 10.0, "{still:?}");
    let stood = rome_maps::geometry::Point::new(still.x_mm, still.y_mm);
    let from_people = rome_maps::geometry::distance(stood, middle);
    assert!(
        from_people < 2_500.0,
        "{from_people:.0} mm from them: {still:?}"
    );
    assert!(
        matches!(still.task.as_deref(), Some("T1" | "T2")),
        "{still:?}"
    );
    let t3 = status(&r, "T3");
    assert_eq!(t3.state, TaskState::Done, "{t3:?}");
    assert_eq!(t3.tried, vec!["r1".to_string()], "{t3:?}");
    // It was sent only once it was back: after its rest, with the people
    // gone.
    let t2 = status(&r, "T2");
    let rest_ms = rome_nav::fleet::duty::REST_FIRST.as_millis() as u64;
    let t2_ended = t2.ended_ms.expect("T2 ended");
    assert!(
        t3.assigned_ms.is_some_and(|a| a >= t2_ended + rest_ms),
        "{t2:?} {t3:?}"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn tasks_that_come_as_a_stream_are_added_when_they_come_and_all_done() {
    // One robot, three short errands, the next 30 s after the last: each
    // is added on the dispatcher's data when it comes, not before, and
    // none is handed to the robot before it was added.
    let ids = ["T1", "T2", "T3"];
    let tasks = ids
        .iter()
        .zip(["352L", "350R", "356R"])
        .map(|(id, to)| (*id, spec(to, None)))
        .collect();
    let every = Duration::from_secs(30);
    let r = run_with(&[("r1", "350R")], tasks, None, |run| {
        run.every = Some(every);
    })
    .await;
    all_done(&r, &ids);
    let added: Vec<u64> = ids.iter().map(|id| status(&r, id).added_ms).collect();
    for pair in added.windows(2) {
        let apart = pair[1] - pair[0];
        // Added at the first tick of the world's clock past its time.
        assert!(
            (30_000..=31_000).contains(&apart),
            "added {apart} ms after the one before: {added:?}"
        );
    }
    for id in ids {
        let s = status(&r, id);
        assert!(s.assigned_ms.is_some_and(|a| a >= s.added_ms), "{s:?}");
    }
}

/// Short errands back and forth along corridor A (5.6 m each: under the
/// 5.5 m of map a correction otherwise needs before the turning space),
/// by a robot whose wheels differ enough to turn it a degree or so a
/// metre; the odometry heading's error at the end, by ground truth.
async fn short_errands(stale_mm: f64) -> f64 {
    let tasks: Vec<_> = (1..=16)
        .map(|k| {
            let to = if k % 2 == 1 { "A342R" } else { "A340L" };
            (format!("T{k}"), to)
        })
        .collect();
    let ids: Vec<(&str, &str, &str)> = tasks
        .iter()
        .map(|(id, to)| (id.as_str(), *to, "r1"))
        .collect();
    let r = run_with(&[("r1", "A340L")], pinned(&ids), None, |run| {
        run.run.noise.wheel_mismatch = 0.004;
        run.run.himm_cfg.stale_mm = stale_mm;
    })
    .await;
    println!("heading off at the end: {:?}", r.heading_off_end);
    r.heading_off_end["r1"]
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_on_short_errands_has_its_heading_corrected() {
    let with = short_errands(rome_nav::himm::HimmConfig::default().stale_mm).await;
    let without = short_errands(0.0).await;
    assert!(
        with.abs() < 5.0,
        "corrected from short maps: {with:.1}° off"
    );
    assert!(without.abs() > 10.0, "never corrected: {without:.1}° off");
}

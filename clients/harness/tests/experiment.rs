//! `rome experiment`'s library: the thesis' rows, the runs and their
//! tables, judged from what happened.

#![allow(clippy::unwrap_used)]

use rome_harness::experiment::{self, Setup, Trial, CHAPTER6};
use rome_harness::RouteSpec;
use rome_maps::{Network, World};
use rome_nav::board::GoalType;
use rome_nav::navigator::NavConfig;
use rome_nav::plan::Plan;
use rome_nav::report::Report;
use rome_sim::Noise;
use std::time::Duration;

fn setup(limit_s: u64, jobs: usize) -> Setup {
    rome_tests::show_warnings_on_failure();
    Setup {
        map: rome_maps::load_named("eb3").unwrap(),
        noise: Noise::default(),
        jobs,
        limit: Duration::from_secs(limit_s),
        cruise_mm_s: None,
        people: 0,
        wall_limit: Duration::from_secs(600),
        nav: Default::default(),
    }
}

/// Thirty people in every run, two runs at a time, cruising at `cruise`
/// mm/s (`None`: the Navigator's own). The robot steers out of people's
/// way at the thesis' gentle rate, heeds only what is within 15° of
/// ahead while it does, drives on beside a person as beside a wall,
/// drives to a corner in the Corner state all the way, and steers back to
/// the middle past people standing: briskly, guarding its front quarter,
/// bearing off a near side, keeping right on the way to a corner or
/// passing wide, it is pushed less often or elsewhere, and these runs
/// are chosen for the pushes and the steering round people that the
/// Navigator must recover from.
fn among_people(limit_s: u64, cruise: Option<f64>) -> Setup {
    let mut s = setup(limit_s, 2);
    s.people = 30;
    s.cruise_mm_s = cruise;
    s.nav.brisk_keep_right = false;
    s.nav.front_quarter_guard = false;
    s.nav.bear_off_near_side = false;
    s.nav.corner_keep_right = false;
    s.nav.pass_wide = false;
    s
}

/// `trial` run with `setup` and, at the same time, with `setup`'s
/// Navigator changed by `without`: the two reports.
async fn with_and_without(
    setup: Setup,
    without: impl FnOnce(&mut NavConfig),
    trial: Trial,
) -> (Report, Report) {
    let mut other = setup.clone();
    without(&mut other.nav);
    let (with, without) = tokio::join!(
        experiment::run_all(&setup, vec![trial.clone()], |_| {}),
        experiment::run_all(&other, vec![trial], |_| {}),
    );
    (
        with[0].report.clone().unwrap(),
        without[0].report.clone().unwrap(),
    )
}

/// `trials` on the built-in `map`, two at a time, cruising at 0.7 m/s.
async fn cruising_on(map: &str, trials: Vec<Trial>) -> Vec<experiment::Outcome> {
    let mut s = setup(900, 2);
    s.map = rome_maps::load_named(map).unwrap();
    s.cruise_mm_s = Some(700.0);
    experiment::run_all(&s, trials, |_| {}).await
}

/// Every run arrived within 0.5 m, and no corner is judged failed.
fn every_run_arrives_and_every_corner_is_clean(out: &[experiment::Outcome]) {
    for o in out {
        let r = o.report.as_ref().unwrap();
        assert!(r.arrived() && r.to_goal_cm.abs() < 50.0, "{}", r.table());
        let corners = experiment::mode_cell(r, GoalType::C);
        assert!(
            !corners.contains('*'),
            "run {}: C {corners}\n{}",
            o.trial.no,
            r.table()
        );
    }
}

fn trial(no: usize, from: &str, to: &str, seed: u64) -> Trial {
    Trial {
        no,
        route: RouteSpec::new("r1", from, to),
        seed,
        thesis: None,
    }
}

#[test]
fn every_route_of_tables_6_1_and_6_2_is_planned_on_eb3() {
    let map = rome_maps::load_named("eb3").unwrap();
    let world = World::from_map(&map);
    let network = Network::new(&map, &world);
    assert_eq!(CHAPTER6.iter().filter(|t| t.table == "6.1").count(), 27);
    assert_eq!(CHAPTER6.iter().filter(|t| t.table == "6.2").count(), 13);
    for t in CHAPTER6 {
        let via: Vec<String> = t.via().iter().map(|v| (*v).to_string()).collect();
        let plan = Plan::through(&world, &network, t.from, &via, t.to)
            .unwrap_or_else(|e| panic!("{} #{} {} to {}: {e}", t.table, t.no, t.from, t.to));
        let m = plan.route.length_mm / 1_000.0;
        // The names are the thesis' places: the route, through the way
        // round where the thesis' robot went the long way (Table 6.2 #4,
        // #5, #6, the last a whole cycle of the building back to the door
        // across the hall), is the distance the thesis' robot drove, within
        // 5 %; all but #8, for which our map has no way round of its
        // length.
        // A light nearer the goal than a braking distance is left to the
        // last leg (6.1 #27's last light is 53 mm from its goal).
        if let [.., l, d] = &plan.steps[..] {
            if l.goal.goal_type == rome_nav::board::GoalType::L {
                assert!(d.goal.distance >= 1_000, "{} #{}: {d:?}", t.table, t.no);
            }
        }
        let long_way = t.table == "6.2" && t.no == 8;
        assert_eq!(
            !via.is_empty(),
            t.table == "6.2" && [4, 5, 6].contains(&t.no)
        );
        let off = (m - t.dist_m).abs() / t.dist_m;
        assert!(
            long_way == (off > 0.05),
            "{} #{} {} to {}: planned {m:.1} m, the thesis drove {} m",
            t.table,
            t.no,
            t.from,
            t.to,
            t.dist_m
        );
    }
    // The default trials are the thesis' rows, with consecutive seeds.
    let trials = experiment::trials(None, 2, 10);
    assert_eq!(trials.len(), 80);
    assert_eq!(trials[40].route.from, "350R");
    assert_eq!((trials[0].seed, trials[79].seed), (10, 89));
    assert_eq!(trials[45].thesis.unwrap().no, 6);
    assert_eq!(
        trials[72].route.via,
        ["359L", "301.secondL"],
        "6.2 #6 the second time"
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn runs_are_tabulated_from_what_happened_and_failures_are_starred_with_a_reason() {
    let outcomes = experiment::run_all(
        &setup(900, 2),
        vec![trial(1, "302L", "A340R", 2), trial(2, "302L", "NOPE", 3)],
        |_| {},
    )
    .await;
    assert_eq!(outcomes.len(), 2);
    let ok = outcomes[0].report.as_ref().unwrap();
    assert!(ok.arrived(), "{}", ok.table());
    assert_eq!(
        [GoalType::L, GoalType::C, GoalType::D].map(|c| experiment::mode_cell(ok, c)),
        ["1/1", "1/1", "1/1"]
    );
    let err = outcomes[1].report.as_ref().unwrap_err();
    assert!(err.contains("NOPE"), "{err}");
    let md = experiment::markdown(&outcomes);
    assert!(md.contains("| 1 | 302L to A340R | 2 | "), "{md}");
    assert!(md.contains("| 2 | 302L to NOPE | 3 | — | Fail* |"), "{md}");
    assert!(md.contains("- No. 2: ") && md.contains("NOPE"), "{md}");
    let csv = experiment::csv(&outcomes);
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 3, "{csv}");
    assert!(rows[1].starts_with("1,302L,A340R,,2,true,"), "{csv}");
    assert!(rows[2].starts_with("2,302L,NOPE,,3,false,"), "{csv}");

    // Given up before it can arrive: its unfinished modes are starred, and
    // the row says why.
    let late = experiment::run_all(&setup(40, 1), vec![trial(1, "302L", "A340R", 2)], |_| {}).await;
    let r = late[0].report.as_ref().unwrap();
    assert!(!r.arrived());
    assert!(
        experiment::mode_cell(r, GoalType::D).starts_with("0*/"),
        "{}",
        r.table()
    );
    let md = experiment::markdown(&late);
    assert!(md.contains("Fail ("), "{md}");
    assert!(!experiment::reason(&late[0]).is_empty());
    let s = experiment::summary(&late);
    assert!(s.starts_with("0 of 1 runs arrived"), "{s}");

    // The same trial alone gives the same row as beside another.
    let alone =
        experiment::run_all(&setup(900, 1), vec![trial(1, "302L", "A340R", 2)], |_| {}).await;
    assert_eq!(
        experiment::csv(&alone).lines().nth(1),
        Some(rows[1]),
        "the same seed, another row"
    );
}

#[test]
fn every_annex_route_is_planned_and_the_west_corridor_has_no_light_segment() {
    let map = rome_maps::load_named("annex").unwrap();
    let world = World::from_map(&map);
    let network = Network::new(&map, &world);
    let routes =
        rome_harness::parse_routes("annex", rome_maps::builtin::routes("annex").unwrap()).unwrap();
    assert_eq!(routes.len(), 10);
    for r in &routes {
        Plan::new(&world, &network, &r.from, &r.to)
            .unwrap_or_else(|e| panic!("{} to {}: {e}", r.from, r.to));
    }
    // South corridor (lights), then up the lightless west one to 110L: the
    // leg after the corner is dead reckoning alone.
    let plan = Plan::new(&world, &network, "221R", "110L").unwrap();
    let modes: String = plan
        .steps
        .iter()
        .map(|s| format!("{:?}", s.goal.goal_type))
        .collect();
    assert_eq!(modes, "LECD", "{modes}");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_short_leg_from_a_standstill_at_a_high_cruise_ends_on_its_goal() {
    // 345R to 345L: one 0.9 m leg along the wall. Braking from the 0.7 m/s
    // asked for, not from the speed reached, would stop at once.
    let mut s = setup(900, 1);
    s.cruise_mm_s = Some(700.0);
    let out = experiment::run_all(&s, vec![trial(1, "345R", "345L", 1)], |_| {}).await;
    let r = out[0].report.as_ref().unwrap();
    assert!(r.to_goal_cm.abs() < 15.0, "{}", r.table());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_run_past_its_wall_limit_is_given_up_as_hung() {
    let mut s = setup(900, 1);
    s.wall_limit = Duration::from_millis(1);
    let out = experiment::run_all(&s, vec![trial(1, "302L", "A340R", 2)], |_| {}).await;
    let err = out[0].report.as_ref().unwrap_err();
    assert!(err.starts_with("hung: still running after"), "{err}");
    assert!(experiment::markdown(&out).contains("- No. 1: hung"));
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_push_spoils_the_odometry_unless_the_base_stops_and_a_light_seen_late_recovers_it() {
    // 6.1 #23 among thirty people at the Navigator's 0.4 m/s. With a base
    // that does not stop itself on a touch (the thesis' Navigator), the
    // robot pushes against people until Check-Bumper's next look, its
    // wheels turning while its body stands, and its odometry runs metres
    // ahead. Measured from where the missed light was counted, every later
    // light would be missed too and the run would end short; measured from
    // where the missed light was seen late, the rest are found. Stopping on
    // the touch and backing off at once, the robot keeps its odometry.
    let (stops, r) = with_and_without(
        among_people(900, None),
        |nav| nav.stop_on_contact = false,
        trial(23, "NE.men.R", "302R", 11),
    )
    .await;
    assert!(stops.contacts.robot > 0, "no touch: {}", stops.table());
    assert!(
        stops.arrived() && stops.to_goal_cm.abs() < 50.0,
        "{}",
        stops.table()
    );
    assert!(
        stops.odometry_error_cm.unwrap() < 50.0,
        "odometry off by {:?} cm: {}",
        stops.odometry_error_cm,
        stops.table()
    );
    assert!(
        r.contacts.robot > 0,
        "no push to recover from: {}",
        r.table()
    );
    assert!(
        r.odometry_error_cm.unwrap() > 150.0,
        "odometry was not spoiled: {}",
        r.table()
    );
    let late: usize = r.lights().map(|l| l.found_late).sum();
    let missed: usize = r.lights().map(|l| l.missed).sum();
    assert!(late >= 1, "no light was found late: {}", r.table());
    assert!(missed <= 1, "{missed} lights missed: {}", r.table());
    assert!(r.arrived() && r.to_goal_cm.abs() < 50.0, "{}", r.table());
    // The people are in the picture, dashed, where they walked.
    assert_eq!(r.people.len(), 30);
    let map = rome_maps::load_named("eb3").unwrap();
    let png = r.picture(&map, &World::from_map(&map), 800);
    let img = image::load_from_memory(&png).unwrap().to_rgb8();
    let purple = img
        .pixels()
        .filter(|p| p.0 == rome_maps::render::PEOPLE)
        .count();
    assert!(purple > 1_000, "{purple} pixels of people's walks");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_annex_narrow_lightless_corridor_is_driven_and_the_plates_after_it_read() {
    // The Annex's west corridor is 2.0 m wide, narrower than any of EB3's,
    // and has no lights. Stopping where the incoming corridor's width puts
    // the turning space left the robot at the edge of the corridor it
    // turned into (runs 4 and 10 ended their corners 24-29° off); a plate
    // on the north corridor's 2.4 m is taller on the image than EB3's 120
    // rows (run 5 missed 201, 203 and 205).
    let world = World::from_map(&rome_maps::load_named("annex").unwrap());
    let out = cruising_on(
        "annex",
        vec![
            trial(4, "112L", "292R", 4),
            trial(5, "110R", "207L", 5),
            trial(10, "221R", "110L", 10),
            trial(2, "223R", "299L", 2),
        ],
    )
    .await;
    every_run_arrives_and_every_corner_is_clean(&out);
    let run = |no: usize| {
        out.iter()
            .find(|o| o.trial.no == no)
            .and_then(|o| o.report.as_ref().ok())
            .unwrap()
    };
    let five = run(5);
    let plates = rome_harness::plates::judge(five, &world);
    assert_eq!(plates.detected, ["201", "203", "205", "207"], "{plates:?}");
    assert!(plates.false_reports.is_empty(), "{plates:?}");
    // Run 4 drives the lightless west corridor's whole length: mapped as
    // an L segment is, its heading stays true, and the plates after it are
    // placed where they are (the odometry had drifted 3 m, all four
    // missed and reported as unnamed).
    let four = run(4);
    let plates = rome_harness::plates::judge(four, &world);
    assert_eq!(
        plates.detected,
        ["223", "201", "203", "205", "291"],
        "{plates:?}"
    );
    assert!(plates.false_reports.is_empty(), "{plates:?}");
    // Run 2's goal is a door on the dead end's end wall, 0.43 m off the
    // corridor's middle: driving up the middle it ended 62 cm away; the
    // last metres now follow the goal's own line.
    let two = run(2);
    assert!(two.miss_cm < 50.0, "{}", two.table());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_robot_left_aside_by_people_steps_onto_its_goals_line() {
    // 6.1 #18's route among thirty people at 0.7 m/s, people placed with
    // seed 8: steering for people near the end, the robot finishes its D
    // goal more than 0.5 m off the goal's line, its odometry good.
    // Measuring itself against the walls the map puts beside the goal, it
    // steps sideways onto the line. (Any change in how the robot drives
    // moves the people it meets: the seed is one where it is left aside.)
    let (steps, stays) = with_and_without(
        among_people(900, Some(700.0)),
        |nav| nav.onto_line = false,
        trial(18, "341L", "311L", 8),
    )
    .await;
    assert!(steps.arrived() && steps.miss_cm < 30.0, "{}", steps.table());
    assert!(stays.miss_cm > 50.0, "not left aside: {}", stays.table());
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn turns_at_crossroads_and_t_junctions_end_heading_into_the_corridor() {
    // The Campus's corridors cross: a turning space there has openings on
    // every side, and no wall ahead of the robot but the far block's
    // corner. Right and left at crossroads, and out at a T-junction.
    let out = cruising_on(
        "campus",
        vec![
            trial(2, "1307R", "406L", 2),
            trial(6, "1801R", "1106L", 6),
            trial(5, "911L", "3038R", 5),
            trial(9, "1707R", "2205L", 9),
        ],
    )
    .await;
    every_run_arrives_and_every_corner_is_clean(&out);
}

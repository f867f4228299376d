//! Door plates judged by ground truth (§6.2, Tables 6.3 and 6.6): which of
//! the plates a robot truly passed on its camera's side the plate finder
//! reported, which it missed, and what it reported that was no plate it
//! passed.
//!
//! A plate counts as *passed* when the robot's true track goes by it with
//! the plate on its left (the sideways camera's side), facing along the
//! plate's wall within 45°, at most 4 m from it, within 0.8 m along the
//! wall of a point of the track (so the plate beside a run's start
//! counts). A report names the map's
//! plate nearest to where the plate finder placed it (within 1.5 m): a
//! passed plate so named is *detected*; a report naming nothing, or a
//! plate the robot did not pass, is *false*; a second report of a plate
//! already detected is a repeat and counts for nothing.
//!
//! The passed plates form *sequences*, one per corridor driven; Table
//! 6.6's events are counted over them: the first plate of a sequence
//! detected (E4) or missed (E1), a later one detected (E5) or missed (E2),
//! and false reports (E9) per later plate.

use crate::confidence::Count;
use rome_maps::geometry::{direction, distance, heading_to, normalize_deg, Point};
use rome_maps::World;
use rome_nav::board::PlateReport;
use rome_nav::report::Report;

/// How far from its wall a plate may be passed and still count, mm.
const PASS_MM: f64 = 4_000.0;
/// How far the robot's heading may be from the plate's wall, degrees.
const PASS_DEG: f64 = 45.0;
/// How far ahead or behind a track point a plate may be and count as
/// abeam of it, mm (track points are at most half a metre apart).
const ABEAM_MM: f64 = 800.0;

/// The routes of Table 6.3, as the EB3 map names their places (the thesis'
/// `V317R` is door 317.2's, `acs.elevator.R` is `acs.elev.R`).
pub const TABLE_6_3: [(&str, &str); 11] = [
    ("352L", "384R"),
    ("381L", "NE.men.L"),
    ("346R", "376R"),
    ("381R", "NE.men.R"),
    ("NE.women.L", "317.2R"),
    ("314L", "340.cmptr.room.R"),
    ("A342L", "A323R"),
    ("acs.elev.R", "376R"),
    ("381R", "NE.men.R"),
    ("NE.women.L", "311.double.R"),
    ("A365L", "301R"),
];

/// One run's plates, judged.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct PlateRun {
    /// Passed and reported, in the order passed.
    pub detected: Vec<String>,
    /// Passed and not reported, in the order passed.
    pub missed: Vec<String>,
    /// Reports of no plate passed (`A331`, or `unnamed at (61.3, 40.2) m`).
    pub false_reports: Vec<String>,
    /// The passed plates, one sequence per corridor, each plate with
    /// whether it was reported.
    pub sequences: Vec<Vec<(String, bool)>>,
}

/// Judges a run's plate reports against what its true track passed.
pub fn judge(report: &Report, world: &World) -> PlateRun {
    judge_track(&report.trail, &report.plates, world)
}

/// Judges `reports` against the plates the true track `trail` passed.
pub fn judge_track(trail: &[Point], reports: &[PlateReport], world: &World) -> PlateRun {
    // Each passed plate with the trail index it was passed at.
    let mut passed: Vec<(usize, &rome_maps::world::PlateAt)> = Vec::new();
    for p in &world.plates {
        let along_wall = direction(p.wall_heading_deg);
        // From some point of the track, facing along its next step, the
        // plate is abeam (within the camera's view along the wall) on the
        // left.
        let hit = trail.windows(2).enumerate().find(|(_, w)| {
            let (a, b) = (w[0], w[1]);
            let step = distance(a, b);
            if step < 1.0 {
                return false;
            }
            let heading = heading_to(a, b);
            if normalize_deg(heading - p.wall_heading_deg).abs() > PASS_DEG {
                return false;
            }
            let d = (b - a) / step;
            let rel = p.at - a;
            let along = rel.dot(&d);
            // The wall's inward side is to the left of its tracing
            // direction, so a plate on it lies left of the robot.
            let left = d.x * rel.y - d.y * rel.x;
            along.abs() <= ABEAM_MM && left > 0.0 && left <= PASS_MM && along_wall.dot(&d) > 0.0
        });
        if let Some((i, _)) = hit {
            passed.push((i, p));
        }
    }
    passed.sort_by_key(|(i, _)| *i);
    let reported: Vec<Option<&str>> = reports.iter().map(|r| r.label.as_deref()).collect();
    let mut run = PlateRun::default();
    let mut last_heading: Option<f64> = None;
    for (_, p) in &passed {
        let seen = reported.contains(&Some(p.label.as_str()));
        if seen {
            run.detected.push(p.label.clone());
        } else {
            run.missed.push(p.label.clone());
        }
        let new_corridor =
            last_heading.is_none_or(|h| normalize_deg(h - p.wall_heading_deg).abs() > PASS_DEG);
        if new_corridor {
            run.sequences.push(Vec::new());
        }
        if let Some(seq) = run.sequences.last_mut() {
            seq.push((p.label.clone(), seen));
        }
        last_heading = Some(p.wall_heading_deg);
    }
    for r in reports {
        match &r.label {
            Some(l) if passed.iter().any(|(_, p)| &p.label == l) => {}
            Some(l) => run.false_reports.push(l.clone()),
            None => run.false_reports.push(format!(
                "unnamed at ({:.1}, {:.1}) m",
                r.x_mm as f64 / 1_000.0,
                r.y_mm as f64 / 1_000.0
            )),
        }
    }
    run
}

/// Table 6.6's events over runs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Events {
    /// E1: the first plate of a sequence missed (of sequences).
    pub e1: Count,
    /// E2: a later plate missed (of later plates).
    pub e2: Count,
    /// E4: the first plate of a sequence detected (of sequences).
    pub e4: Count,
    /// E5: a later plate detected (of later plates).
    pub e5: Count,
    /// E9: false reports (of later plates).
    pub e9: Count,
}

/// The thesis' Table 6.6 (the events it estimates from counts).
pub const THESIS_EVENTS: Events = Events {
    e1: Count { ok: 0, of: 11 },
    e2: Count { ok: 19, of: 162 },
    e4: Count { ok: 11, of: 11 },
    e5: Count { ok: 132, of: 162 },
    e9: Count { ok: 11, of: 162 },
};

impl Events {
    /// Counts the events of `runs`.
    pub fn of_runs<'a>(runs: impl IntoIterator<Item = &'a PlateRun>) -> Events {
        let mut e = Events::default();
        for run in runs {
            let mut later = 0;
            for seq in &run.sequences {
                for (k, (_, seen)) in seq.iter().enumerate() {
                    let (hit, miss) = if k == 0 {
                        (&mut e.e4, &mut e.e1)
                    } else {
                        later += 1;
                        (&mut e.e5, &mut e.e2)
                    };
                    hit.of += 1;
                    miss.of += 1;
                    if *seen {
                        hit.ok += 1;
                    } else {
                        miss.ok += 1;
                    }
                }
            }
            e.e9.ok += run.false_reports.len();
            e.e9.of += later;
        }
        e
    }
}

/// Table 6.3 (one row per run: detected, missed, false) and Table 6.6
/// (the events, ours beside the thesis'), with the chance of reading every
/// plate of a corridor of N plates, p5^N.
pub fn markdown(rows: &[(String, PlateRun)]) -> String {
    let mut s = String::from(
        "| Run | Correctly detected | Missed | False detections |\n|-----|--------------------|--------|------------------|\n",
    );
    let list = |v: &[String]| {
        if v.is_empty() {
            "—".to_string()
        } else {
            v.join(", ")
        }
    };
    for (name, r) in rows {
        s.push_str(&format!(
            "| {name} | {} | {} | {} |\n",
            list(&r.detected),
            list(&r.missed),
            list(&r.false_reports)
        ));
    }
    let passed: usize = rows
        .iter()
        .map(|(_, r)| r.detected.len() + r.missed.len())
        .sum();
    let detected: usize = rows.iter().map(|(_, r)| r.detected.len()).sum();
    let false_n: usize = rows.iter().map(|(_, r)| r.false_reports.len()).sum();
    let share = if passed == 0 {
        0.0
    } else {
        100.0 * detected as f64 / passed as f64
    };
    s.push_str(&format!(
        "\n{detected} of {passed} plates passed detected ({share:.1} %), {false_n} false detection(s)\n"
    ));
    let e = Events::of_runs(rows.iter().map(|(_, r)| r));
    let t = THESIS_EVENTS;
    s.push_str(
        "\n| Event | Description | Ours | Thesis |\n|-------|-------------|-----:|-------:|\n",
    );
    for (name, what, o, th) in [
        (
            "E1",
            "false negative at the beginning of a detection sequence",
            e.e1,
            t.e1,
        ),
        (
            "E2",
            "false negative in the middle of a detection sequence",
            e.e2,
            t.e2,
        ),
        (
            "E4",
            "a true landmark at the beginning of a detection sequence",
            e.e4,
            t.e4,
        ),
        (
            "E5",
            "a true landmark in the middle of a detection sequence",
            e.e5,
            t.e5,
        ),
        (
            "E9",
            "detecting a false positive (per later landmark)",
            e.e9,
            t.e9,
        ),
    ] {
        s.push_str(&format!(
            "| {name} | {what} | {o} = {:.4} | {th} = {:.4} |\n",
            o.ratio(),
            th.ratio()
        ));
    }
    let (p5, tp5) = (e.e5.ratio(), t.e5.ratio());
    s.push_str(&format!(
        "\nEvery plate of a corridor with N plates read: p5^N = {p5:.4}^N (thesis {tp5:.4}^N); N = 10: {:.3} (thesis {:.3})\n",
        p5.powi(10),
        tp5.powi(10)
    ));
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn report(label: Option<&str>) -> PlateReport {
        PlateReport {
            frame: 1,
            x_mm: 12_000,
            y_mm: 28_000,
            bbox: [0, 0, 1, 1],
            label: label.map(String::from),
            error_mm: None,
        }
    }

    #[test]
    fn a_plate_passed_on_the_left_is_detected_or_missed_and_anything_else_is_false() {
        // Figure 5.3's building: plate L1L2 on the north wall at
        // (17.6, 30.0) m, the corridor's centre line 1.5 m south of it.
        let map = rome_maps::load_named("fig5_3").unwrap();
        let world = World::from_map(&map);
        let east: Vec<Point> = (0..40)
            .map(|k| Point::new(10_000.0 + 400.0 * k as f64, 28_500.0))
            .collect();
        let run = judge_track(
            &east,
            &[report(Some("L1L2")), report(Some("301")), report(None)],
            &world,
        );
        assert_eq!(run.detected, ["L1L2"]);
        assert!(run.missed.is_empty());
        assert_eq!(run.false_reports.len(), 2, "{run:?}");
        assert!(
            run.false_reports[0] == "301"
                && run.false_reports[1].starts_with("unnamed at (12.0, 28.0) m")
        );
        let run = judge_track(&east, &[], &world);
        assert_eq!(run.missed, ["L1L2"]);
        assert_eq!(run.sequences, vec![vec![("L1L2".to_string(), false)]]);
        // Driven westwards the plate is on the right, out of the camera's
        // view: not passed, so its report is false.
        let west: Vec<Point> = east.iter().rev().copied().collect();
        let run = judge_track(&west, &[report(Some("L1L2"))], &world);
        assert!(run.detected.is_empty() && run.missed.is_empty());
        assert_eq!(run.false_reports, ["L1L2"]);
    }

    #[test]
    fn events_count_first_and_later_plates_of_each_sequence() {
        let run = PlateRun {
            detected: vec![],
            missed: vec![],
            false_reports: vec!["x".into()],
            sequences: vec![
                vec![("a".into(), true), ("b".into(), false), ("c".into(), true)],
                vec![("d".into(), false)],
            ],
        };
        let e = Events::of_runs([&run]);
        assert_eq!((e.e4.ok, e.e4.of, e.e1.ok), (1, 2, 1));
        assert_eq!((e.e5.ok, e.e5.of, e.e2.ok), (1, 2, 1));
        assert_eq!((e.e9.ok, e.e9.of), (1, 2));
        // The thesis' p5.
        assert!((THESIS_EVENTS.e5.ratio() - 0.8148).abs() < 5e-5);
    }
}

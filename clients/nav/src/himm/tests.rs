//! Tests of `himm`.

use super::*;
use rome_maps::geometry::{pt, Point};

fn corridor(heading_deg: f64, width_mm: f64) -> Grid {
    // A robot driving along a corridor, its side sonars hitting both
    // walls every 40 mm (a scan every 0.1 s at 0.4 m/s).
    let mut g = Grid::new(pt(0.0, 0.0), 12_000.0);
    let d = direction(heading_deg);
    for k in 0..250 {
        let s = -5_000.0 + 40.0 * f64::from(k);
        let at = Point::origin() + d * s;
        let side = width_mm / 2.0 - SONAR_RING_MM;
        g.add(at, heading_deg + 90.0, side as u32);
        g.add(at, heading_deg - 90.0, side as u32);
    }
    g
}

#[test]
fn himm_raises_the_echo_cell_and_lowers_the_path() {
    let mut g = Grid::new(pt(0.0, 0.0), 2_000.0);
    for _ in 0..6 {
        g.add(pt(0.0, 0.0), 0.0, 1_000);
    }
    let hits = g.occupied(15);
    assert_eq!(hits.len(), 1);
    let (Point { coords: c }, _) = hits[0];
    let (x, y) = (c.x, c.y);
    assert!(x.abs() < 100.0 && (y - 1_380.0).abs() < 100.0, "{x} {y}");
    // A later echo farther along the same axis clears the old cell.
    for _ in 0..15 {
        g.add(pt(0.0, 0.0), 0.0, 1_800);
    }
    assert!(g.occupied(1).iter().all(|(p, _)| p.y > 2_000.0));
}

#[test]
fn the_hough_transform_finds_the_corridor_orientation() {
    for heading in [0.0, 7.0, 90.0, -33.0, 180.0 - 4.0] {
        let g = corridor(heading, 3_660.0);
        let a = hallway_orientation(&g.occupied(6), 1_000.0).expect("two walls");
        let err = normalize_deg(2.0 * (a - heading)) / 2.0;
        assert!(err.abs() <= 1.0, "heading {heading}: found {a}");
    }
}

#[test]
fn both_walls_are_placed_within_a_few_centimetres() {
    for heading in [0.0, 90.0, -33.0] {
        let g = corridor(heading, 3_660.0);
        let w = hallway_walls(&g.occupied(6), 1_000.0, Some((pt(0.0, 0.0), 5_000.0)))
            .expect("two walls");
        let mut d = w.beside(pt(0.0, 0.0), heading);
        d.sort_by(f64::total_cmp);
        assert!((d[0] + 1_830.0).abs() < 80.0, "heading {heading}: {d:?}");
        assert!((d[1] - 1_830.0).abs() < 80.0, "heading {heading}: {d:?}");
    }
}

#[test]
fn the_sideways_error_is_where_the_walls_put_the_robot_against_odometry() {
    // Heading North along x = 0 in a 3.66 m corridor. The robot is truly
    // 300 mm right (East) of the middle; odometry says 200 mm left.
    let corridor = Corridor {
        x_mm: 0.0,
        y_mm: 0.0,
        heading_deg: 0.0,
        left_mm: Some(1_830.0),
        right_mm: Some(1_830.0),
        no_lights: false,
    };
    // In the odometry frame the walls stand 2130 mm left and 1530 mm
    // right of where odometry puts the robot.
    let walls = HallwayWalls {
        orientation_deg: 0.0,
        normal: rome_maps::geometry::Vector::new(1.0, 0.0),
        rho: [-2_330.0, 1_330.0],
    };
    let shift = sideways_fix(&walls, pt(-200.0, 5_000.0), &corridor, 400.0).expect("a fix");
    assert!((shift + 500.0).abs() < 1e-6, "{shift}");
    // Walls much wider apart than the map's are not this corridor's.
    let wide = HallwayWalls {
        rho: [-3_330.0, 1_330.0],
        ..walls
    };
    assert_eq!(
        sideways_fix(&wide, pt(-200.0, 5_000.0), &corridor, 400.0),
        None
    );
    // Without the map's walls there is nothing to compare with.
    let unknown = Corridor {
        left_mm: None,
        ..corridor
    };
    assert_eq!(
        sideways_fix(&walls, pt(-200.0, 5_000.0), &unknown, 400.0),
        None
    );
}

#[test]
fn one_wall_alone_gives_no_orientation() {
    let mut g = Grid::new(pt(0.0, 0.0), 12_000.0);
    for k in 0..250 {
        g.add(pt(0.0, -5_000.0 + 40.0 * f64::from(k)), 90.0, 1_000);
    }
    assert_eq!(hallway_orientation(&g.occupied(6), 1_000.0), None);
}

#[test]
fn the_directionless_rule_picks_the_side_nearer_the_goal() {
    assert_eq!(orient(3.0, 0.0), 3.0);
    assert_eq!(orient(3.0, 180.0), -177.0);
    assert_eq!(orient(178.0, 0.0), -2.0);
    assert_eq!(orient(92.0, -90.0), -88.0);
}

#[test]
fn walls_are_checked_against_the_robots_track() {
    // 10 m due West (heading 90) with the walls found at 93°: 3° off.
    let off = track_disagreement(93.0, pt(0.0, 0.0), pt(-10_000.0, 0.0), 6_000.0).unwrap();
    assert!((off - 3.0).abs() < 1e-9, "{off}");
    // Directionless: walls at -87° are the same line as 93°.
    let off = track_disagreement(-87.0, pt(0.0, 0.0), pt(-10_000.0, 0.0), 6_000.0).unwrap();
    assert!((off - 3.0).abs() < 1e-9, "{off}");
    // Heading North while the walls run East-West: a side corridor.
    let off = track_disagreement(90.0, pt(0.0, 0.0), pt(0.0, 8_000.0), 6_000.0).unwrap();
    assert!((off - 90.0).abs() < 1e-9, "{off}");
    // Too short a track to tell.
    assert_eq!(
        track_disagreement(0.0, pt(0.0, 0.0), pt(0.0, 2_000.0), 6_000.0),
        None
    );
}

#[test]
fn a_track_that_strays_across_the_hallway_still_runs_along_it() {
    let cfg = HimmConfig {
        track_side_mm: FLEET_TRACK_SIDE_MM,
        ..HimmConfig::default()
    };
    // Alone, the limit is the thesis-like 6° whatever the track's length.
    assert_eq!(HimmConfig::default().track_tolerance_deg(2_000.0), 6.0);
    // A robot that kept right 0.4 m over a 2 m map: its track runs 11.3°
    // off the corridor's walls, which are the hallway all the same.
    let off = track_disagreement(90.0, pt(0.0, 0.0), pt(-2_000.0, -400.0), 1_500.0).unwrap();
    assert!(off > cfg.max_track_deg && off <= cfg.track_tolerance_deg(2_000.0));
    // One whose odometry turns 1.4°/m: over 9.4 m its straight track runs
    // 6.6° off the walls placed near it now.
    assert!(6.6 <= cfg.track_tolerance_deg(9_400.0));
    // Walls across the track are not the hallway's, however short it is.
    let off = track_disagreement(0.0, pt(0.0, 0.0), pt(-2_000.0, 0.0), 1_500.0).unwrap();
    assert!(off > cfg.track_tolerance_deg(2_000.0), "{off}");
    // Nor are walls 20° off a long track.
    assert!(20.0 > cfg.track_tolerance_deg(6_000.0));
}

#[test]
fn drift_is_learnt_over_everything_driven_since_the_heading_was_found() {
    let cfg = HimmConfig::default();
    let d = Drift::default();
    // 100 m of legs too short to map, then a 12° correction over a 6 m
    // map: 0.8 × 12° / 100 m is learnt, not 0.8 × 12° / 6 m.
    for _ in 0..200 {
        d.drove(500.0);
    }
    d.learn(12.0, &cfg);
    let rate = d.get() * 1_000.0;
    assert!((rate - 0.8 * 12.0 / 100.0).abs() < 1e-9, "{rate} °/m");
    // The count starts again at a correction: 2 m after it is too little
    // to learn from.
    d.drove(2_000.0);
    d.learn(5.0, &cfg);
    assert!((d.get() * 1_000.0 - rate).abs() < 1e-12);
    // And where the heading was found good.
    d.drove(10_000.0);
    d.found();
    d.drove(4_000.0);
    d.learn(1.0, &cfg);
    let now = d.get() * 1_000.0;
    assert!((now - (rate + 0.8 * 1.0 / 4.0)).abs() < 1e-9, "{now} °/m");
}

#[test]
fn a_short_map_serves_only_a_heading_stale_for_10_m() {
    let cfg = HimmConfig::default();
    // 2 m of map, 12 m driven since the heading was last found: enough.
    assert!(cfg.short_map_serves(2_000.0, 12_000.0));
    // Found 8 m ago: the map must grow to its usual length.
    assert!(!cfg.short_map_serves(2_000.0, 8_000.0));
    // Stale, but the map too short to place walls on.
    assert!(!cfg.short_map_serves(1_500.0, 50_000.0));
    // Turned off.
    let off = HimmConfig {
        stale_mm: 0.0,
        ..cfg
    };
    assert!(!off.short_map_serves(5_000.0, 50_000.0));
}

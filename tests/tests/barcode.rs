//! The elevator-marker reader (`rome_nav::barcode`) on the simulator's own
//! sideways-camera images, pixel noise on: every code is read at the
//! doors, from the distances and angles a robot stands at in front of
//! them, and nothing else in the buildings (door plates, posters, glass
//! bricks, doors) is taken for a marker.

use rome_maps::geometry::{direction, heading_to, normalize_deg, Point};
use rome_maps::marker::{Code, MARGIN_MM, P_MM, STRIPES};
use rome_maps::model::EdgeKind;
use rome_nav::barcode::{find, Found, ReaderConfig};
use rome_sim::camera::{side_image, PixelNoise, SIDE_RANGE_MM};
use rome_sim::rng::Rng;
use rome_sim::scene::{Scene, Sense};
use rome_sim::spec::{sonar_bearing_deg, Noise, IMAGE_SIZE, ROBOT_RADIUS_MM, SIDE_FOV_DEG};

fn focal() -> f64 {
    f64::from(IMAGE_SIZE.0) / 2.0 / (SIDE_FOV_DEG / 2.0).to_radians().tan()
}

/// The sideways camera's image from `at`, heading `heading`, read for
/// markers in its middle half, as the Navigator scans while it looks.
fn look(scene: &Scene, at: Point, heading: f64, rng: &mut Rng, noise: &PixelNoise) -> Vec<Found> {
    let open = vec![false; scene.elevators.len()];
    let img = side_image(scene, &open, at, heading, &[], IMAGE_SIZE, noise, rng);
    let h = IMAGE_SIZE.1;
    find(&img, h / 4..3 * h / 4, &ReaderConfig::default())
}

/// EB3 with its two elevators painted `codes`.
fn eb3_painted(codes: [Code; 2]) -> Scene {
    let mut map = rome_maps::load_named("eb3").expect("eb3 loads");
    let doors = map
        .rings
        .iter_mut()
        .flat_map(|r| r.edges.iter_mut())
        .filter(|e| e.kind == EdgeKind::Elevator);
    for (edge, code) in doors.zip(codes) {
        edge.tags.insert("marker".into(), code.to_string());
    }
    Scene::new(&map)
}

#[test]
fn every_code_is_read_in_front_of_the_door_from_near_and_far_and_askew() {
    let mut rng = Rng::new(17);
    let noise = PixelNoise::new(Noise::default().pixel, &mut rng);
    let all = Code::all();
    let mut read = 0;
    for (k, &code) in all.iter().enumerate() {
        let other = all[(k + 1) % all.len()];
        let scene = eb3_painted([code, other]);
        for e in &scene.elevators {
            let door = &scene.walls[e.door];
            let want = door.marker.expect("painted");
            let middle = door.a + door.dir * (door.len / 2.0);
            for d in [1_500.0, 2_200.0, 3_000.0] {
                for slide in [-500.0, 0.0, 500.0] {
                    for askew in [-10.0, 0.0, 10.0] {
                        let eye = middle + door.normal * d + door.dir * slide;
                        let axis = heading_to(eye, middle) + askew;
                        // Only views that hold the whole paper: a robot
                        // turns until it has it (§5.4.6).
                        let half = MARGIN_MM + P_MM * STRIPES as f64 / 2.0;
                        let in_view = [-half, half].iter().all(|&u| {
                            let off = normalize_deg(heading_to(eye, middle + door.dir * u) - axis);
                            off.abs() < SIDE_FOV_DEG / 2.0 - 1.0
                        });
                        if !in_view {
                            continue;
                        }
                        let at = eye - direction(axis) * ROBOT_RADIUS_MM;
                        let heading = axis - sonar_bearing_deg(18);
                        let found = look(&scene, at, heading, &mut rng, &noise);
                        let what = format!(
                            "{want} at {}, {d} mm off, {slide} along, {askew}°",
                            e.number
                        );
                        assert_eq!(found.len(), 1, "{what}: {found:?}");
                        let f = &found[0];
                        assert_eq!(f.code, want, "{what}");
                        // Where it is: bearing within a degree, range
                        // within a tenth.
                        let bearing = normalize_deg(heading_to(eye, middle) - axis);
                        let got = f.bearing_deg(IMAGE_SIZE.0, focal());
                        assert!(
                            (got - bearing).abs() < 1.0,
                            "{what}: bearing {got} vs {bearing}"
                        );
                        let range = (middle - eye).norm();
                        let est = f.distance_mm(focal()) * (bearing.to_radians().cos());
                        assert!(
                            (est / range - 1.0).abs() < 0.1,
                            "{what}: {est:.0} mm vs {range:.0}"
                        );
                        read += 1;
                    }
                }
            }
        }
    }
    // Most views hold the whole paper.
    assert!(read > 5 * 2 * 20, "{read} views");
    println!("{read} views, every one read");
}

#[test]
fn nothing_else_in_the_buildings_is_taken_for_a_marker() {
    let mut rng = Rng::new(23);
    let noise = PixelNoise::new(Noise::default().pixel, &mut rng);
    let mut looked = 0;
    let mut true_finds = 0;
    let mut busy = std::collections::BTreeMap::<&str, usize>::new();
    for name in ["eb3", "annex", "campus"] {
        let map = rome_maps::load_named(name).expect("map loads");
        let scene = Scene::new(&map);
        let open = vec![false; scene.elevators.len()];
        let spots: Vec<Point> = scene
            .world
            .positions
            .values()
            .map(|p| p.in_corridor())
            .step_by(3)
            .collect();
        // Views from the corridor, and views head-on at every plate,
        // poster, stretch of glass bricks and marker from one to three
        // metres.
        let mut views: Vec<(Point, f64)> = spots
            .iter()
            .enumerate()
            .map(|(i, &at)| (at, (i as f64 * 67.0) % 360.0))
            .collect();
        for w in &scene.walls {
            let mut things: Vec<f64> = w.plates.iter().map(|(_, u)| *u).collect();
            things.extend(&w.posters);
            if w.bricks {
                things.extend([w.len / 4.0, w.len / 2.0]);
            }
            for (k, u) in things.into_iter().enumerate() {
                let target = w.a + w.dir * u;
                let eye = target + w.normal * (1_000.0 + 700.0 * (k % 3) as f64);
                let axis = heading_to(eye, target) + 8.0 * (k % 3) as f64 - 8.0;
                let at = eye - direction(axis) * ROBOT_RADIUS_MM;
                views.push((at, axis - sonar_bearing_deg(18)));
            }
            // A marker from far enough to hold its paper.
            if w.marker.is_some() {
                let target = w.a + w.dir * (w.len / 2.0);
                let eye = target + w.normal * 2_500.0;
                let axis = heading_to(eye, target);
                let at = eye - direction(axis) * ROBOT_RADIUS_MM;
                views.push((at, axis - sonar_bearing_deg(18)));
            }
        }
        for (at, heading) in views {
            let axis = heading + sonar_bearing_deg(18);
            let eye = at + direction(axis) * ROBOT_RADIUS_MM;
            // What the middle of the image looks at, to show the finder
            // was shown the things that could fool it.
            if let Some((_, wi, _)) = scene.ray(eye, axis, SIDE_RANGE_MM, Sense::Sight, &open, None)
            {
                let w = &scene.walls[wi];
                for (thing, there) in [
                    ("plate", !w.plates.is_empty()),
                    ("poster", !w.posters.is_empty()),
                    ("glass bricks", w.bricks),
                    ("door", w.kind == EdgeKind::Door),
                ] {
                    *busy.entry(thing).or_default() += usize::from(there);
                }
            }
            for f in look(&scene, at, heading, &mut rng, &noise) {
                let off = (f.column + 0.5 - f64::from(IMAGE_SIZE.0) / 2.0) / focal();
                let hit = scene.ray(
                    eye,
                    axis - off.atan().to_degrees(),
                    SIDE_RANGE_MM,
                    Sense::Sight,
                    &open,
                    None,
                );
                let wall = hit.map(|(_, wi, _)| &scene.walls[wi]);
                assert_eq!(
                    wall.and_then(|w| w.marker),
                    Some(f.code),
                    "{name}: a marker {} read at {at:?} heading {heading}, column {:.0}, where the camera sees {:?}",
                    f.code,
                    f.column,
                    wall.map(|w| (&w.kind, &w.number))
                );
                true_finds += 1;
            }
            looked += 1;
        }
    }
    assert!(looked > 300, "{looked} images");
    assert!(
        true_finds >= 2,
        "the markers in view were read: {true_finds}"
    );
    for thing in ["plate", "poster", "glass bricks", "door"] {
        assert!(
            busy.get(thing).copied().unwrap_or(0) > 0,
            "no {thing} in view: {busy:?}"
        );
    }
    println!("{looked} images, {true_finds} true markers, in view: {busy:?}");
}

//! Elevator cars in a world of several floors: a robot drives into the
//! cabin on one floor, rides, and drives out on another; the doors wait
//! for a robot in the doorway; floors do not see each other.

use rome_maps::geometry::{direction, distance, heading_to, Point};
use rome_sim::elevator::{CarSpec, DoorState};
use rome_sim::spec::ROBOT_RADIUS_MM;
use rome_sim::{Noise, Pose, Sim, SimConfig};

fn tower() -> (Sim, rome_maps::plane::Plane) {
    let building = rome_maps::load_building_named("tower").expect("the tower loads");
    let config = SimConfig {
        noise: Noise::none(),
        ..SimConfig::default()
    };
    Sim::for_building(&building, config, CarSpec::default()).expect("a world of the tower")
}

/// The middle of elevator `name`'s door, and the unit normal into the
/// corridor.
fn door(sim: &Sim, name: &str) -> (Point, rome_maps::geometry::Vector, usize) {
    let e = sim
        .scene()
        .elevators
        .iter()
        .position(|e| e.number == name)
        .expect("the door is in the scene");
    let w = &sim.scene().walls[sim.scene().elevators[e].door];
    (w.a + w.dir * (w.len / 2.0), w.normal, e)
}

/// Runs until `done` holds, at most `limit_ms` of simulated time.
fn run_until(sim: &mut Sim, limit_ms: u64, what: &str, done: impl Fn(&Sim) -> bool) {
    let end = sim.time_ms() + limit_ms;
    while !done(sim) {
        assert!(sim.time_ms() < end, "not within {limit_ms} ms: {what}");
        sim.step();
    }
}

fn doors_open_at(sim: &Sim, floor: &str) -> bool {
    let car = sim.car("acs.elev").expect("a car");
    car.at_floor() == Some(floor) && matches!(car.doors(), DoorState::Open { .. })
}

#[test]
fn a_robot_rides_from_floor_3_to_floor_5_and_drives_out_there() {
    let (mut sim, plane) = tower();
    let (middle, normal, _) = door(&sim, "3:acs.elev");
    let start = middle + normal * 1_200.0;
    let facing = heading_to(start, middle);
    sim.add_robot("r1", Pose::new(start.x, start.y, facing))
        .expect("r1 in front of the door");
    // Shut, the door stops the robot.
    sim.robot_mut(0)
        .drive
        .move_by(2_000.0, 300.0, 300.0)
        .expect("move");
    sim.run_for(10_000);
    assert!(distance(sim.robot(0).pose.at, start) < 1_200.0 - ROBOT_RADIUS_MM + 20.0);
    assert!(sim.robot(0).contacts.wall > 0, "it met the shut door");
    let met = sim.robot(0).contacts.wall;
    // Back off, call the car, and drive in when the doors are open.
    sim.robot_mut(0)
        .drive
        .move_by(-500.0, 300.0, 300.0)
        .expect("back");
    sim.run_for(5_000);
    sim.call_elevator("3:acs.elev").expect("call");
    run_until(&mut sim, 20_000, "the doors open on 3", |s| {
        doors_open_at(s, "3")
    });
    sim.robot_mut(0)
        .drive
        .move_by(2_300.0, 300.0, 300.0)
        .expect("in");
    sim.run_for(12_000);
    let (_, _, cabin3) = door(&sim, "3:acs.elev");
    assert!(
        sim.scene().in_cabin(cabin3, sim.robot(0).pose.at),
        "r1 is in the car"
    );
    // Turn round, then ride to 5.
    sim.robot_mut(0)
        .drive
        .turn(180.0, 45.0, 45.0)
        .expect("turn");
    sim.run_for(8_000);
    let inside = sim.robot(0).pose;
    sim.car_mut("acs.elev")
        .expect("car")
        .stop_at("5")
        .expect("5");
    run_until(&mut sim, 40_000, "the doors open on 5", |s| {
        doors_open_at(s, "5")
    });
    let (_, _, cabin5) = door(&sim, "5:acs.elev");
    let rode = sim.robot(0).pose;
    assert!(
        sim.scene().in_cabin(cabin5, rode.at),
        "r1 came up with the car"
    );
    let (floor, local) = plane.local(rode.at).expect("on a floor");
    let (_, before) = plane.local(inside.at).expect("on a floor");
    assert_eq!(floor, "5");
    // The tower's floors are one plan: the same place in the cabin.
    assert!(distance(local, before) < 1e-6, "{local:?} vs {before:?}");
    assert!((rode.heading.deg() - inside.heading.deg()).abs() < 1e-9);
    // Out into floor 5's corridor, touching nothing on the way.
    sim.robot_mut(0)
        .drive
        .move_by(2_500.0, 300.0, 300.0)
        .expect("out");
    sim.run_for(12_000);
    let out = sim.robot(0).pose.at;
    let (m5, n5, _) = door(&sim, "5:acs.elev");
    assert!(
        (out - m5).dot(&n5) > 800.0,
        "r1 is out in the corridor of 5"
    );
    assert_eq!(plane.local(out).map(|(f, _)| f), Some("5"));
    assert_eq!(sim.robot(0).contacts.wall, met, "no touch since the door");
    assert_eq!(sim.robot(0).contacts.robot, 0);
}

#[test]
fn the_doors_wait_for_a_robot_in_the_doorway_and_floors_do_not_see_each_other() {
    let (mut sim, _) = tower();
    let (middle, normal, e3) = door(&sim, "3:acs.elev");
    sim.call_elevator("3:acs.elev").expect("call");
    run_until(&mut sim, 20_000, "the doors open on 3", |s| {
        doors_open_at(s, "3")
    });
    // A robot standing in the doorway, for longer than the dwell.
    let at = middle;
    sim.add_robot("r1", Pose::new(at.x, at.y, heading_to(at, at - normal)))
        .expect("r1 in the doorway");
    let dwell = CarSpec::default().dwell_ms;
    sim.run_for(dwell * 2);
    assert!(doors_open_at(&sim, "3"), "the doors wait for r1");
    assert_eq!(sim.elevator_open("3:acs.elev"), Some(true));
    // It backs out: the doors shut after the dwell, and the door is solid.
    sim.robot_mut(0)
        .drive
        .move_by(-1_500.0, 300.0, 300.0)
        .expect("out");
    run_until(&mut sim, dwell + 10_000, "the doors shut", |s| {
        s.car("acs.elev")
            .is_some_and(|c| c.doors() == DoorState::Closed)
    });
    assert_eq!(sim.elevator_open("3:acs.elev"), Some(false));
    assert!(!sim.scene().in_cabin(e3, sim.robot(0).pose.at));
    // Floor 4 at the same place of its plan: r1's sonar on 3 does not hear
    // r2 on 4.
    let r1 = sim.robot(0).pose;
    let (m4, _, _) = door(&sim, "4:acs.elev");
    let on4 = r1.at + (m4 - middle) + direction(r1.heading.deg()) * 600.0;
    sim.add_robot("r2", Pose::new(on4.x, on4.y, r1.heading.deg()))
        .expect("r2 on floor 4");
    sim.sense(0);
    let alone = sim.robot(0).sonar;
    let (mut other, _) = tower();
    other.add_robot("r1", r1).expect("r1 alone");
    other.sense(0);
    assert_eq!(alone, other.robot(0).sonar, "r2 is on another floor");
}

/// The tower with acs.elev's cabin on floor 3 bare metal (`metal`) or
/// covered, noise on, and r1 standing in its open doorway, facing in.
fn in_the_cabin(metal: bool) -> Sim {
    let mut building = rome_maps::load_building_named("tower").expect("the tower loads");
    if metal {
        for e in building.floors[0]
            .map
            .rings
            .iter_mut()
            .flat_map(|r| r.edges.iter_mut())
        {
            if e.number.as_deref() == Some("acs.elev") {
                e.tags.insert("cabin".into(), "metal".into());
            }
        }
    }
    let (mut sim, _) = Sim::for_building(&building, SimConfig::default(), CarSpec::default())
        .expect("a world of the tower");
    sim.call_elevator("3:acs.elev").expect("call");
    run_until(&mut sim, 20_000, "the doors open on 3", |s| {
        doors_open_at(s, "3")
    });
    let (middle, normal, _) = door(&sim, "3:acs.elev");
    let at = middle - normal * 400.0;
    sim.add_robot("r1", Pose::new(at.x, at.y, heading_to(middle, at)))
        .expect("r1 in the doorway");
    sim
}

#[test]
fn a_bare_metal_cabin_gives_spurious_sonar_and_infrared_readings() {
    let forward_ir = |bits: u32| bits & 0b0110 != 0;
    let mut counts = Vec::new();
    for metal in [false, true] {
        let mut sim = in_the_cabin(metal);
        let (mut ir, mut far) = (0, 0);
        for _ in 0..200 {
            sim.step();
            sim.sense(0);
            let r = sim.robot(0);
            ir += usize::from(forward_ir(r.infrared));
            // The back wall is 1.2 m ahead of the sonar ring.
            far += usize::from(f64::from(r.sonar[12]) > 1_700.0);
        }
        counts.push((ir, far));
    }
    // Covered (as the thesis' robot rode it): the back wall is out of the
    // detectors' reach and the sonar reads it (but for an echo missed now
    // and then, 0.2 %); bare: both lie often.
    assert_eq!(counts[0].0, 0, "covered: infrared");
    assert!(
        counts[0].1 <= 2,
        "covered: sonar read long {} times",
        counts[0].1
    );
    let (ir, far) = counts[1];
    // Each of the two detectors half the time: three times in four.
    assert!(
        (120..=180).contains(&ir),
        "forward infrared fired {ir} of 200 times"
    );
    assert!(
        (40..=120).contains(&far),
        "forward sonar read long {far} of 200 times"
    );
}

//! Runs between floors (§5.4.6): "the initial and final locations can be
//! either on the same floor or different floors". The Planner plans the
//! walk on the first floor to the elevator door with the thesis' segments,
//! hands the Navigator the ride as a goal of its own (V, [`RideInfo`]),
//! puts the robot down again outside the door on the other floor, and
//! plans the walk from there.
//!
//! Each floor's plan is in that floor's map coordinates; after the ride
//! the robot's odometry is set to the corridor point outside the door on
//! the new floor, facing out of the car, as at the start of a run.

use crate::board::{Board, Goal, GoalType, RideInfo, Var};
use crate::plan::{Plan, Step};
use crate::planner::{self, Handed, Progress};
use crate::report::judge_step;
use crate::NavError;
use rome_client::sim::TruthClient;
use rome_client::RobotClient;
use rome_maps::building::Building;
use rome_maps::geometry::{distance, heading_to, Point, Pose};
use rome_maps::model::EdgeKind;
use rome_maps::World;

/// How long the Navigator waits for a car to come or to arrive, seconds.
pub const RIDE_WAIT_S: f64 = 180.0;

/// A run through a building.
#[derive(Debug, Clone)]
pub struct FloorPlan {
    /// Start, `FLOOR:POSITION`.
    pub from: String,
    /// Goal, `FLOOR:POSITION`.
    pub to: String,
    /// The walk on each floor: the floor's name and its plan, one or two.
    pub walks: Vec<(String, Plan)>,
    /// The ride between the two walks (a V step).
    pub ride: Option<Step>,
    /// Where the robot is put down after the ride, on the second floor:
    /// the corridor point outside the door, facing out.
    pub exit: Option<Pose>,
}

/// Where an elevator's door is on a floor: its middle on the wall and the
/// corridor point in front of it (on the line of lights).
fn door(world: &World, number: &str) -> Option<(Point, Point)> {
    let l = world.position(&format!("{number}L"))?;
    let r = world.position(&format!("{number}R"))?;
    let wall = Point::from((l.at.coords + r.at.coords) / 2.0);
    let (a, b) = (l.in_corridor(), r.in_corridor());
    Some((wall, Point::from((a.coords + b.coords) / 2.0)))
}

impl FloorPlan {
    /// Plans from `FLOOR:POSITION` to `FLOOR:POSITION` in `building`.
    pub fn new(building: &Building, from: &str, to: &str) -> Result<FloorPlan, NavError> {
        let route = building.route(from, to)?;
        let name = |k: usize| building.floors[k].name.clone();
        let mut walks: Vec<(String, Plan)> = route
            .walks
            .iter()
            .map(|(k, r)| {
                let world = &building.floors[*k].world;
                (name(*k), Plan::segment(world, r.clone()))
            })
            .collect();
        let (Some(number), [(fa, _), (fb, _)]) = (&route.ride, route.walks.as_slice()) else {
            return Ok(FloorPlan {
                from: from.into(),
                to: to.into(),
                walks,
                ride: None,
                exit: None,
            });
        };
        let (a, b) = (&building.floors[*fa], &building.floors[*fb]);
        let missing =
            |f: &str| NavError::Config(format!("elevator {number} has no door on floor {f}"));
        let (wall_a, at_a) = door(&a.world, number).ok_or_else(|| missing(&a.name))?;
        let (wall_b, at_b) = door(&b.world, number).ok_or_else(|| missing(&b.name))?;
        let marker = a
            .map
            .rings
            .iter()
            .flat_map(|r| &r.edges)
            .filter(|e| e.kind == EdgeKind::Elevator && e.number.as_deref() == Some(number))
            .find_map(|e| rome_maps::marker::of_edge(e)?.ok())
            .ok_or_else(|| {
                NavError::Config(format!(
                    "elevator {number} has no marker on floor {} (`marker=BITS` on its door): the Navigator finds the door by it",
                    a.name
                ))
            })?;
        let subpath = walks[0].1.steps.last().map_or(1, |s| s.subpath + 1);
        let ride = RideInfo {
            elevator: number.clone(),
            marker: marker.to_string(),
            from: a.name.clone(),
            to: b.name.clone(),
            door_mm: distance(at_a, wall_a).round() as i64,
            exit_mm: distance(at_b, wall_b).round() as i64,
            wait_s: RIDE_WAIT_S,
        };
        let step = Step {
            goal: Goal {
                goal_type: GoalType::V,
                distance: 0,
                direction_deg: heading_to(at_a, wall_a),
            },
            subpath,
            light_offsets_mm: Vec::new(),
            from: at_a,
            to: at_b,
            walls_mm: None,
            end_wall_mm: None,
            goal_walls_mm: None,
            ride: Some(ride),
        };
        // The second walk's subpaths go on from the ride's.
        for s in &mut walks[1].1.steps {
            s.subpath += subpath;
        }
        Ok(FloorPlan {
            from: from.into(),
            to: to.into(),
            walks,
            ride: Some(step),
            exit: Some(Pose::new(at_b.x, at_b.y, heading_to(wall_b, at_b))),
        })
    }

    /// Every step, the ride among them, in the order they are handed over.
    pub fn steps(&self) -> Vec<&Step> {
        let mut out: Vec<&Step> = self.walks[0].1.steps.iter().collect();
        out.extend(&self.ride);
        if let Some((_, plan)) = self.walks.get(1) {
            out.extend(&plan.steps);
        }
        out
    }

    /// The plan in the thesis' notation, with the floor of each walk.
    pub fn describe(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (k, (floor, plan)) in self.walks.iter().enumerate() {
            out.push(format!("floor {floor}:"));
            out.extend(plan.describe().into_iter().map(|l| format!("  {l}")));
            if k == 0 {
                if let Some(ride) = &self.ride {
                    let p = Plan {
                        steps: vec![ride.clone()],
                        ..plan.clone()
                    };
                    out.extend(p.describe());
                }
            }
        }
        out
    }
}

/// Runs `fp`: the first floor's goals, the ride, the second floor's. The
/// robot must have been put down at the start (as for one floor:
/// [`planner::put_down`]). Stops after a goal the Navigator ended.
pub async fn run(
    board: &Board,
    robot: &RobotClient,
    fp: &FloorPlan,
    truth: Option<&TruthClient>,
    mut progress: impl FnMut(Progress<'_>),
) -> Result<Vec<Handed>, NavError> {
    let first = &fp.walks[0].1;
    let mut out = planner::run(board, first, truth, &mut progress).await?;
    let (Some(step), Some(exit), Some((_, second))) = (&fp.ride, fp.exit, fp.walks.get(1)) else {
        return Ok(out);
    };
    if out.len() < first.steps.len() {
        return Ok(out);
    }
    board.set(Var::Ride, &step.ride).await?;
    board.give_goal(&step.goal).await?;
    let mut handed = Handed::new(out.len(), step);
    progress(Progress::Handed(&handed));
    planner::await_status(board).await?;
    let ended = planner::failed(board).await;
    if let Some(t) = truth {
        handed.truth = t.get().await.ok();
    }
    handed.failure = ended
        .clone()
        .or_else(|| judge_step(step, handed.truth.as_ref(), None));
    progress(Progress::Done(&handed));
    out.push(handed);
    if ended.is_some() {
        return Ok(out);
    }
    // Put down on the new floor, as at a run's start.
    robot
        .set_pose(
            exit.at.x.round() as i64,
            exit.at.y.round() as i64,
            exit.heading.deg(),
        )
        .await?;
    planner::turn_onto(robot, second, exit.heading.deg()).await?;
    let offset = out.len();
    let rest = planner::run(board, second, truth, |p| match p {
        Progress::Handed(h) => progress(Progress::Handed(&Handed {
            index: h.index + offset,
            ..h.clone()
        })),
        Progress::Done(h) => progress(Progress::Done(&Handed {
            index: h.index + offset,
            ..h.clone()
        })),
        other => progress(other),
    })
    .await?;
    out.extend(rest.into_iter().map(|h| Handed {
        index: h.index + offset,
        ..h
    }));
    Ok(out)
}

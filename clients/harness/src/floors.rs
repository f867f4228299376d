//! Runs between floors of a building in one process (§5.4.6): the world
//! holds every floor and a car in every shaft, each with its elevator
//! server; each robot's crew drives the first floor's walk, rides, and
//! drives the second's ([`rome_nav::floors`]). Robots that want one car
//! take turns through its session. A run is judged by ground truth,
//! floor included.

use crate::{connect, members, monitored, Harness, RunConfig};
use rome_client::sim::TruthClient;
use rome_maps::geometry::distance;
use rome_maps::plane::Plane;
use rome_nav::crew::Reports;
use rome_nav::floors::{self, FloorPlan};
use rome_nav::planner::{self, Handed, Progress};
use rome_nav::NavError;
use rome_schema::sim::Truth;
use rome_schema::Root;
use rome_sim::{Camera, Pose};
use std::time::{Duration, Instant};

/// Faults to inject into a run between floors.
#[derive(Debug, Clone, Default)]
pub struct FloorFaults {
    /// Robots whose sideways camera is covered: they cannot see a marker.
    pub side_covered: Vec<String>,
    /// Cars out of order: they take calls and never come.
    pub out_of_order: Vec<String>,
    /// An elevator whose server is stopped as soon as its car first moves
    /// with a robot in it, and started again this much simulated time
    /// later.
    pub outage: Option<(String, Duration)>,
}

/// How one robot's run between floors went.
#[derive(Debug, Clone)]
pub struct FloorsReport {
    /// The robot.
    pub robot: String,
    /// The plan.
    pub plan: FloorPlan,
    /// Every goal handed over, with its verdict (the ride among them).
    pub steps: Vec<Handed>,
    /// Where the robot truly ended: its floor and that floor's
    /// coordinates.
    pub end: Truth,
    /// How far from the goal it ended, on the goal's floor, mm (`None`
    /// when it ended on another floor).
    pub miss_mm: Option<f64>,
    /// Touches of walls and robots during the run.
    pub contacts: u32,
    /// Simulated time from the start until this robot was done.
    pub run_time: Duration,
    /// Wall time it took.
    pub wall_time: Duration,
    /// Why the run ended before its goal, if it did.
    pub failure: Option<String>,
    /// Where it truly went, as its floor's name and that floor's
    /// coordinates.
    pub trail: Vec<(String, rome_maps::geometry::Point)>,
}

impl FloorsReport {
    /// Whether it ended on the goal's floor within `mm` of the goal.
    pub fn arrived_within(&self, mm: f64) -> bool {
        self.failure.is_none() && self.miss_mm.is_some_and(|m| m <= mm)
    }

    /// The ride, as handed over and judged, if it got that far.
    pub fn ride(&self) -> Option<&Handed> {
        self.steps
            .iter()
            .find(|h| h.step.goal.goal_type == rome_nav::board::GoalType::V)
    }
}

/// What a run between floors left: each robot's report, and each car's
/// session holder at the end (`None`: free).
#[derive(Debug, Clone)]
pub struct FloorsRun {
    /// Each robot's report, in the order of the routes.
    pub robots: Vec<FloorsReport>,
    /// Each elevator and who holds its session at the end.
    pub sessions: Vec<(String, Option<String>)>,
}

/// Runs every robot of `cfg.routes` from its `FLOOR:POSITION` to its other
/// in `cfg.building`, with `faults`; `progress` hears each goal handed over
/// and judged, with the robot's index.
pub async fn run_floors(
    mut cfg: RunConfig,
    faults: FloorFaults,
    mut progress: impl FnMut(usize, Progress<'_>),
) -> Result<FloorsRun, NavError> {
    let building = cfg
        .building
        .clone()
        .ok_or_else(|| NavError::Config("a run between floors needs a building".into()))?;
    // The plate finder names plates of one map; floors have their own.
    cfg.plfinder = false;
    let plane = Plane::new(&building);
    let mut plans = Vec::new();
    let mut starts = Vec::new();
    for r in &cfg.routes {
        let fp = FloorPlan::new(&building, &r.from, &r.to)?;
        let floor = building
            .floor(&fp.walks[0].0)
            .ok_or_else(|| NavError::Config(format!("no floor {}", fp.walks[0].0)))?;
        let first = &fp.walks[0].1;
        let at = first.ends().0 + plane.floors[floor].offset;
        starts.push((
            r.robot.clone(),
            Pose::new(at.x, at.y, first.start_heading_deg),
        ));
        plans.push((fp, building.floors[floor].world.clone()));
    }
    let wall = Instant::now();
    monitored(cfg.lockstep, |clock| async move {
        let mut rig = Harness::start(&cfg, &starts, cfg.net.clone()).await?;
        {
            let mut sim = rig.world.lock();
            for name in &faults.side_covered {
                let i = sim.index(name).map_err(|e| NavError::Config(e.to_string()))?;
                sim.cover_camera(i, Camera::Side);
            }
            for car in &faults.out_of_order {
                sim.car_mut(car)
                    .ok_or_else(|| NavError::Config(format!("no elevator '{car}'")))?
                    .out_of_order(true);
            }
        }
        let session = rig.session.clone();
        let mut crews = tokio::task::JoinSet::new();
        let mut drivers = tokio::task::JoinSet::new();
        let (tx, mut rx) = tokio::sync::mpsc::unbounded_channel::<(usize, Handed, bool)>();
        for (k, ((fp, world), r)) in plans.iter().zip(&cfg.routes).enumerate() {
            let name = r.robot.clone();
            for member in members(&cfg, world, r.cruise_mm_s) {
                let role = member.role();
                let (board, robot) = connect(&session, &name, role).await?;
                crews.spawn(rome_clock::wrap(&format!("{name} {role}"), async move {
                    let r = member.run(robot, board, Reports::default()).await;
                    (k, r.map(|_| role))
                }));
            }
            let (board, robot) = connect(&session, &name, "planner").await?;
            let truth = TruthClient::new(&session, &Root::default(), &name)?;
            let (fp, tx) = (fp.clone(), tx.clone());
            drivers.spawn(rome_clock::wrap(&format!("{name} planner"), async move {
                let r = async {
                    planner::put_down(&robot, &fp.walks[0].1, None).await?;
                    floors::run(&board, &robot, &fp, Some(&truth), |p| match p {
                        Progress::Handed(h) => drop(tx.send((k, h.clone(), false))),
                        Progress::Done(h) => drop(tx.send((k, h.clone(), true))),
                        _ => {}
                    })
                    .await
                }
                .await;
                let _ = robot.stop(false).await;
                (k, r.err().map(|e| format!("the Planner stopped: {e}")))
            }));
        }
        drop(tx);
        let t0 = rig.world.lock().time_ms();
        let _stepper = match clock {
            Some(clock) => rig.world.start_lockstep(clock, cfg.speed, |_| {}),
            None => rig.world.start(Some(cfg.wall_speed())),
        };
        let n = cfg.routes.len();
        let mut steps: Vec<Vec<Handed>> = vec![Vec::new(); n];
        let mut ended: Vec<Option<(Option<String>, u64)>> = vec![None; n];
        let mut outage: Option<(String, Duration, Option<u64>)> =
            faults.outage.clone().map(|(car, d)| (car, d, None));
        let mut tick = rome_clock::interval(cfg.period(500.0));
        // A server stopped is started again before the run ends, so that
        // what it does when it comes back is seen.
        let down = |o: &Option<(String, Duration, Option<u64>)>| {
            o.as_ref().is_some_and(|(_, _, since)| since.is_some())
        };
        while ended.iter().any(Option::is_none) || down(&outage) {
            tokio::select! {
                biased;
                Some((k, h, done)) = rome_clock::idle(rx.recv()) => {
                    if done {
                        steps[k].push(h.clone());
                        progress(k, Progress::Done(&h));
                    } else {
                        progress(k, Progress::Handed(&h));
                    }
                }
                Some(Ok((k, failure))) = drivers.join_next() => {
                    let now = rig.world.lock().time_ms();
                    ended[k].get_or_insert((failure, now));
                }
                Some(Ok((k, r))) = crews.join_next() => {
                    let why = match r {
                        Ok(who) => format!("the {who} stopped before the run ended"),
                        Err(e) => format!("a navigation client failed: {e}"),
                    };
                    let now = rig.world.lock().time_ms();
                    ended[k].get_or_insert((Some(why), now));
                }
                _ = tick.tick() => {
                    let now = rig.world.lock().time_ms();
                    if let Some((car, down_for, since)) = &mut outage {
                        match since {
                            None => {
                                let riding = rig.world.lock().car(car).is_some_and(|c| c.moving());
                                if riding {
                                    rig.stop_elevator(car).await;
                                    *since = Some(now);
                                }
                            }
                            Some(t) if now >= *t + down_for.as_millis() as u64 => {
                                rig.start_elevator(car).await?;
                                outage = None;
                            }
                            Some(_) => {}
                        }
                    }
                    if Duration::from_millis(now - t0) > cfg.limit {
                        for e in ended.iter_mut().filter(|e| e.is_none()) {
                            *e = Some((Some(format!("the robot did not arrive within {:?} of simulated time", cfg.limit)), now));
                        }
                    }
                }
            }
        }
        drivers.abort_all();
        crews.abort_all();
        while drivers.join_next().await.is_some() {}
        while crews.join_next().await.is_some() {}
        // Who holds each car's session now that every robot is done.
        let mut sessions = Vec::new();
        for (car, _) in rig.world.lock().cars() {
            sessions.push((car.to_string(), None));
        }
        let (_, probe) = connect(&session, &cfg.routes[0].robot, "monitor").await?;
        for (car, holder) in &mut sessions {
            // The next state published, not the last: a session given back
            // in this instant shows in the next.
            let client = rome_client::elevator::ElevatorClient::beside(&probe, car).await?;
            let states = client.states().await?;
            let next = rome_clock::timeout(Duration::from_secs(5), states.next()).await;
            *holder = match next {
                Ok(Some(Ok(s))) => s.lock.map(|l| l.holder),
                _ => Some(format!("unknown: elevator {car} published no state")),
            };
        }
        let mut robots = Vec::new();
        for (k, ((fp, _), r)) in plans.iter().zip(&cfg.routes).enumerate() {
            let (end, contacts, trail) = {
                let i = rig.index[k];
                let end = rome_sim_hardware::truth::truth_of(&rig.world, i);
                let sim = rig.world.lock();
                let r = sim.robot(i);
                let trail = r
                    .trail
                    .iter()
                    .filter_map(|p| plane.local(p.at).map(|(f, at)| (f.to_string(), at)))
                    .collect();
                (end, r.contacts.total(), trail)
            };
            let (failure, t1) = ended[k].clone().unwrap_or((None, t0));
            let miss_mm = fp.walks.last().and_then(|(floor, plan)| {
                (end.floor.as_deref() == Some(floor.as_str()))
                    .then(|| distance(Pose::from(&end).at, plan.ends().1))
            });
            let steps = std::mem::take(&mut steps[k]);
            // A goal the Navigator ended stops the run early, with its
            // reason.
            let failure = failure.or_else(|| {
                (steps.len() < fp.steps().len())
                    .then(|| steps.last().and_then(|h| h.failure.clone()))
                    .flatten()
            });
            robots.push(FloorsReport {
                robot: r.robot.clone(),
                plan: fp.clone(),
                steps,
                end,
                miss_mm,
                contacts,
                run_time: Duration::from_millis(t1 - t0),
                wall_time: wall.elapsed(),
                failure,
                trail,
            });
        }
        rig.stop().await;
        Ok(FloorsRun { robots, sessions })
    })
    .await
}

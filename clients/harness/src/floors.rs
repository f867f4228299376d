//! A run between floors of a building in one process (§5.4.6): the world
//! holds every floor and a car in every shaft, each with its elevator
//! server; the robot's crew drives the first floor's walk, rides, and
//! drives the second's ([`rome_nav::floors`]). It is judged by ground
//! truth, floor included.

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
use rome_sim::Pose;
use std::time::{Duration, Instant};

/// How a run between floors went.
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
    /// Simulated time the run took.
    pub run_time: Duration,
    /// Wall time it took.
    pub wall_time: Duration,
    /// Why the run ended before its goal, if it did.
    pub failure: Option<String>,
}

impl FloorsReport {
    /// Whether it ended on the goal's floor within `mm` of the goal.
    pub fn arrived_within(&self, mm: f64) -> bool {
        self.failure.is_none() && self.miss_mm.is_some_and(|m| m <= mm)
    }
}

/// Runs robot `cfg.routes[0]` from its `FLOOR:POSITION` to its other in
/// `cfg.building`; `progress` hears each goal handed over and judged.
pub async fn run_floors(
    mut cfg: RunConfig,
    mut progress: impl FnMut(Progress<'_>),
) -> Result<FloorsReport, NavError> {
    let building = cfg
        .building
        .clone()
        .ok_or_else(|| NavError::Config("a run between floors needs a building".into()))?;
    let [route] = cfg.routes.as_slice() else {
        return Err(NavError::Config(format!(
            "a run between floors drives one robot; {} routes given",
            cfg.routes.len()
        )));
    };
    let (name, from, to) = (route.robot.clone(), route.from.clone(), route.to.clone());
    let fp = FloorPlan::new(&building, &from, &to)?;
    // The plate finder names plates of one map; floors have their own.
    cfg.plfinder = false;
    let plane = Plane::new(&building);
    let floor_a = building
        .floor(&fp.walks[0].0)
        .ok_or_else(|| NavError::Config(format!("no floor {}", fp.walks[0].0)))?;
    let first = fp.walks[0].1.clone();
    let (start, _) = first.ends();
    let at = start + plane.floors[floor_a].offset;
    let start_pose = Pose::new(at.x, at.y, first.start_heading_deg);
    let world_a = building.floors[floor_a].world.clone();
    let wall = Instant::now();
    monitored(cfg.lockstep, |clock| async move {
        let rig = Harness::start(&cfg, &[(name.clone(), start_pose)], cfg.net.clone()).await?;
        let session = rig.session.clone();
        let mut tasks = tokio::task::JoinSet::new();
        for member in members(&cfg, &world_a, cfg.routes[0].cruise_mm_s) {
            let role = member.role();
            let (board, robot) = connect(&session, &name, role).await?;
            tasks.spawn(rome_clock::wrap(&format!("{name} {role}"), async move {
                let r = member.run(robot, board, Reports::default()).await;
                r.map(|_| role)
            }));
        }
        let (board, robot) = connect(&session, &name, "planner").await?;
        let truth = TruthClient::new(&session, &Root::default(), &name)?;
        let t0 = rig.world.lock().time_ms();
        let _stepper = match clock {
            Some(clock) => rig.world.start_lockstep(clock, cfg.speed, |_| {}),
            None => rig.world.start(Some(cfg.wall_speed())),
        };
        let mut steps = Vec::new();
        let drive = async {
            planner::put_down(&robot, &first, None).await?;
            floors::run(&board, &robot, &fp, Some(&truth), |p| {
                if let Progress::Done(h) = p {
                    steps.push(h.clone());
                }
                progress(p);
            })
            .await
        };
        let limit = rome_clock::sleep(cfg.limit);
        let failure = tokio::select! {
            biased;
            r = drive => r.err().map(|e| format!("the Planner stopped: {e}")),
            Some(done) = tasks.join_next() => Some(match done {
                Ok(Ok(who)) => format!("the {who} stopped before the run ended"),
                Ok(Err(e)) => format!("a navigation client failed: {e}"),
                Err(e) => format!("a client task failed: {e}"),
            }),
            _ = limit => Some(format!("the robot did not arrive within {:?} of simulated time", cfg.limit)),
        };
        let _ = robot.stop(false).await;
        tasks.abort_all();
        while tasks.join_next().await.is_some() {}
        let (end, contacts, t1) = {
            let k = rig.index[0];
            let end = rome_sim_hardware::truth::truth_of(&rig.world, k);
            let sim = rig.world.lock();
            (end, sim.robot(k).contacts.total(), sim.time_ms())
        };
        rig.stop().await;
        let miss_mm = fp.walks.last().and_then(|(floor, plan)| {
            (end.floor.as_deref() == Some(floor.as_str()))
                .then(|| distance(Pose::from(&end).at, plan.ends().1))
        });
        // A goal the Navigator ended stops the run early, with its reason.
        let failure = failure.or_else(|| {
            (steps.len() < fp.steps().len())
                .then(|| steps.last().and_then(|h| h.failure.clone()))
                .flatten()
        });
        Ok(FloorsReport {
            robot: name,
            plan: fp.clone(),
            steps,
            end,
            miss_mm,
            contacts,
            run_time: Duration::from_millis(t1 - t0),
            wall_time: wall.elapsed(),
            failure,
        })
    })
    .await
}

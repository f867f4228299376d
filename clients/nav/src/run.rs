//! A whole run in one process (`rome demo`): the data server, a simulated
//! robot with its hardware servers, and every navigation client on one
//! in-process Zenoh session, driving from one room to another. The result
//! is a row of Table 6.1 and the trajectory drawn on the map.

use crate::board::Board;
use crate::ctracker::{CTracker, SegmentLog, TrackConfig};
use crate::himm::{Himm, HimmConfig};
use crate::navigator::{NavConfig, NavLog, Navigator};
use crate::plan::{ModeCount, Plan};
use crate::planner::{self, Handed};
use crate::plfinder::{PlConfig, PlFinder};
use crate::NavError;
use rome_client::net::NetOptions;
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_hardware::robot::{spawn_sim_robot, Rates};
use rome_hardware::sim::SimWorld;
use rome_maps::geometry::{direction, distance, Point};
use rome_maps::render::{self, Shape};
use rome_maps::{Map, Network, World};
use rome_schema::Root;
use rome_sim::{Noise, Pose, Sim, SimConfig};
use std::time::{Duration, Instant};
use tokio::sync::mpsc;

/// What to run.
#[derive(Debug, Clone)]
pub struct RunConfig {
    /// The map.
    pub map: Map,
    /// Start position (`350R`).
    pub from: String,
    /// Goal position (`376L`).
    pub to: String,
    /// The robot's name.
    pub robot: String,
    /// Seed of the simulated world.
    pub seed: u64,
    /// Sensor noise and wheel slip.
    pub noise: Noise,
    /// Simulated time per real time.
    pub speed: f64,
    /// Give up after this much simulated time.
    pub limit: Duration,
    /// Give up when the robot has not moved half a metre in this much
    /// simulated time (pinned against a wall, say).
    pub stuck: Duration,
    /// How the Navigator drives.
    pub nav: NavConfig,
    /// How the CTracker tracks.
    pub track: TrackConfig,
    /// Whether the local mapper corrects the heading.
    pub himm: bool,
    /// Whether the plate finder looks for door plates.
    pub plfinder: bool,
}

impl RunConfig {
    /// A run on `map` with the defaults: noise on, 4 × real time.
    pub fn new(map: Map, from: &str, to: &str) -> RunConfig {
        RunConfig {
            map,
            from: from.into(),
            to: to.into(),
            robot: "r1".into(),
            seed: 1,
            noise: Noise::default(),
            speed: 4.0,
            limit: Duration::from_secs(3_600),
            stuck: Duration::from_secs(180),
            nav: NavConfig::default(),
            track: TrackConfig::default(),
            himm: true,
            plfinder: true,
        }
    }
}

/// Something to show while the robot drives.
#[derive(Debug, Clone)]
pub enum Event {
    /// The plan, before the robot moves.
    Planned(Plan),
    /// A goal handed to the Navigator.
    Goal(Handed),
    /// Once a simulated second or so: where the robot truly is.
    Tick {
        /// Simulated time, s.
        time_s: f64,
        /// True pose.
        pose: Pose,
        /// Distance driven, mm.
        travelled_mm: f64,
    },
}

/// The outcome of a run: a row of Table 6.1 and more.
#[derive(Debug, Clone)]
pub struct Report {
    /// Start and goal.
    pub from: String,
    /// Goal.
    pub to: String,
    /// The plan.
    pub plan: Plan,
    /// Distance driven, m (the thesis' "Actual Dist.").
    pub driven_m: f64,
    /// Signed distance to the goal along the last leg, cm: positive past
    /// it, negative short of it.
    pub to_goal_cm: f64,
    /// Distance from the goal across the last leg, cm.
    pub off_line_cm: f64,
    /// Straight-line distance from the goal, cm.
    pub miss_cm: f64,
    /// Simulated run time.
    pub run_time: Duration,
    /// Wall-clock time it took.
    pub wall_time: Duration,
    /// Modes the plan needs.
    pub modes_needed: ModeCount,
    /// Modes completed.
    pub modes_done: ModeCount,
    /// The true trajectory.
    pub trail: Vec<Point>,
    /// What the Navigator did.
    pub nav: NavLog,
    /// What the CTracker did, per L segment.
    pub lights: Vec<SegmentLog>,
    /// Door plates reported.
    pub plates: Vec<crate::board::PlateReport>,
    /// Heading corrections made.
    pub fixes: Vec<crate::board::HeadingFix>,
    /// Why the run was given up, when it was (the robot did not arrive).
    pub failure: Option<String>,
}

impl Report {
    /// Whether the run reached the goal: not given up, and within a metre.
    pub fn arrived(&self) -> bool {
        self.failure.is_none() && self.miss_cm < ARRIVED_CM
    }

    /// The row in the layout of Table 6.1.
    pub fn table(&self) -> String {
        let secs = self.run_time.as_secs();
        let frac = |done: usize, need: usize| format!("{done}/{need}");
        format!(
            "{:<4}{:<22}{:>12}{:>16}{:>11}{:>7}{:>7}{:>7}\n{:<4}{:<22}{:>12.3}{:>+16.0}{:>11}{:>7}{:>7}{:>7}",
            "No.",
            "Path",
            "Actual (m)",
            "To goal (cm)",
            "Run time",
            "L",
            "C",
            "D",
            "1",
            format!("{} to {}", self.from, self.to),
            self.driven_m,
            self.to_goal_cm,
            format!("{}:{:02}", secs / 60, secs % 60),
            frac(self.modes_done.l, self.modes_needed.l),
            frac(self.modes_done.c, self.modes_needed.c),
            frac(self.modes_done.d, self.modes_needed.d),
        )
    }

    /// The trajectory on the map, as PNG bytes.
    pub fn picture(&self, map: &Map, world: &World, width_px: u32) -> Vec<u8> {
        let mut overlay = render::route_shapes(&self.plan.route);
        for w in self.trail.windows(2) {
            overlay.push(Shape::Line {
                a: w[0],
                b: w[1],
                color: render::TRACK,
                width: 2.0,
                dashed: false,
            });
        }
        if let Some(end) = self.trail.last() {
            overlay.push(Shape::Dot {
                at: *end,
                radius: 4.0,
                color: render::TRACK,
            });
        }
        for p in &self.plates {
            overlay.push(Shape::Dot {
                at: (p.x_mm as f64, p.y_mm as f64),
                radius: 3.0,
                color: render::FOUND,
            });
        }
        let img = render::raster(map, world, width_px, &overlay);
        let mut out = std::io::Cursor::new(Vec::new());
        // Encoding an in-memory RGB image cannot fail.
        let _ = img.write_to(&mut out, image::ImageFormat::Png);
        out.into_inner()
    }
}

/// The world side of a run: a simulated robot put down at the plan's
/// start, its hardware servers and a data server, on one Zenoh session.
/// The world does not step until [`SimWorld::start`] is called on
/// [`Rig::world`].
pub struct Rig {
    /// The session the servers use.
    pub session: zenoh::Session,
    /// The simulated world.
    pub world: SimWorld,
    /// The robot's index in it.
    pub index: usize,
    servers: Vec<rome_hardware::robot::Running>,
    data: rome_data::Running,
}

impl Rig {
    /// Builds the world for `plan` and starts the servers on a session
    /// opened with `net`; returns once every server is alive.
    pub async fn start(cfg: &RunConfig, plan: &Plan, net: NetOptions) -> Result<Rig, NavError> {
        if !(cfg.speed.is_finite() && cfg.speed > 0.0) {
            return Err(NavError::Config(format!(
                "the simulation speed must be a positive number, got {}",
                cfg.speed
            )));
        }
        let (start, _) = plan.ends();
        let mut sim = Sim::new(
            &cfg.map,
            SimConfig {
                seed: cfg.seed,
                noise: cfg.noise.clone(),
                ..SimConfig::default()
            },
        );
        let index = sim
            .add_robot(
                &cfg.robot,
                Pose {
                    x: start.0,
                    y: start.1,
                    heading: plan.start_heading_deg,
                },
            )
            .map_err(|e| NavError::Config(e.to_string()))?;
        let world = SimWorld::new(sim);
        // The servers' clocks follow the simulated one.
        let scale = |ms: f64| Duration::from_secs_f64((ms / 1_000.0 / cfg.speed).max(0.002));
        let rates = Rates {
            state: Some(scale(100.0)),
            scan: Some(scale(25.0)),
            camera: scale(500.0),
        };
        let session = net
            .open()
            .await
            .map_err(|e| NavError::Config(e.to_string()))?;
        let root = Root::default();
        let data = rome_data::spawn(
            session.clone(),
            rome_data::ServerConfig {
                root: root.clone(),
                ..Default::default()
            },
        );
        let servers = spawn_sim_robot(&session, &root, &world, &cfg.robot, rates)
            .map_err(|e| NavError::Config(e.to_string()))?;
        for device in ["base", "proximity", "camera/up", "camera/side"] {
            rome_client::alive::await_server(
                &session,
                &root,
                "robot",
                &format!("{}/{device}", cfg.robot),
                Duration::from_secs(10),
            )
            .await?;
        }
        Ok(Rig {
            session,
            world,
            index,
            servers,
            data,
        })
    }

    /// Where the robot truly is.
    pub fn truth(&self) -> Pose {
        self.world.lock().robot(self.index).pose
    }

    /// Stops the servers and closes the session.
    pub async fn stop(self) {
        for s in self.servers {
            let _ = s.stop().await;
        }
        let _ = self.data.stop().await;
        let _ = self.session.close().await;
    }
}

/// Runs the robot from `from` to `to`; `progress` hears what happens.
pub async fn run(cfg: RunConfig, mut progress: impl FnMut(Event)) -> Result<Report, NavError> {
    let wall = Instant::now();
    let world_map = World::from_map(&cfg.map);
    let network = Network::new(&cfg.map, &world_map);
    let plan = Plan::new(&world_map, &network, &cfg.from, &cfg.to)?;
    progress(Event::Planned(plan.clone()));

    let (_, goal) = plan.ends();
    let rig = Rig::start(&cfg, &plan, NetOptions::isolated()).await?;
    let (session, root, world, index) = (
        rig.session.clone(),
        Root::default(),
        rig.world.clone(),
        rig.index,
    );
    let connect = |role: &'static str| {
        let session = session.clone();
        let root = root.clone();
        let robot = cfg.robot.clone();
        async move {
            let ds = DataClient::connect(
                &session,
                DataOptions {
                    root: root.clone(),
                    ..DataOptions::new(role)
                },
            )
            .await?;
            let rc = RobotClient::connect(
                &session,
                &robot,
                RobotOptions {
                    root,
                    ..RobotOptions::new(role)
                },
            )
            .await?;
            Ok::<_, NavError>((Board::new(ds, &robot), rc))
        }
    };

    let (pboard, probot) = connect("planner").await?;
    // The world steps only once everything is up, so the run's clock
    // starts with the robot at the start.
    let stepper = world.start(Some(cfg.speed));
    planner::put_down(&probot, &plan, None).await?;
    let scale = |ms: f64| Duration::from_secs_f64((ms / 1_000.0 / cfg.speed).max(0.002));

    let mut tasks = tokio::task::JoinSet::new();
    let (nav_tx, mut nav_rx) = mpsc::unbounded_channel::<NavLog>();
    {
        let (board, robot) = connect("navigator").await?;
        let nav_cfg = cfg.nav.clone();
        tasks.spawn(async move {
            let mut nav = Navigator::new(robot, board, nav_cfg);
            let r = nav.run_reporting(&nav_tx).await;
            r.map(|_| "navigator")
        });
    }
    let (seg_tx, mut seg_rx) = mpsc::unbounded_channel::<SegmentLog>();
    {
        let (board, robot) = connect("ctracker").await?;
        let track = cfg.track.clone();
        tasks.spawn(async move {
            CTracker::new(robot, board, track)
                .run(Some(seg_tx))
                .await
                .map(|_| "ctracker")
        });
    }
    if cfg.himm {
        let (board, robot) = connect("himm").await?;
        tasks.spawn(async move {
            Himm::new(robot, board, HimmConfig::default())
                .run()
                .await
                .map(|_| "himm")
        });
    }
    if cfg.plfinder {
        let (board, robot) = connect("plfinder").await?;
        let pl = PlConfig::with_map(&world_map);
        tasks.spawn(async move {
            PlFinder::new(robot, board, pl)
                .run()
                .await
                .map(|_| "plfinder")
        });
    }

    let pose_of = |w: &SimWorld| {
        let sim = w.lock();
        let r = sim.robot(index);
        (sim.time_ms(), r.pose, r.travelled_mm)
    };
    let t0 = pose_of(&world).0;
    // Goals handed so far: a run given up still shows the modes it got to.
    let mut handed_so_far: Vec<Handed> = Vec::new();
    let mut failure = None;
    let outcome = {
        let (htx, mut hrx) = mpsc::unbounded_channel::<Handed>();
        let plan_run = planner::run(&pboard, &plan, move |h| {
            let _ = htx.send(h.clone());
        });
        tokio::pin!(plan_run);
        let mut tick = tokio::time::interval(scale(1_000.0));
        let mut moved = (t0, 0.0f64);
        loop {
            tokio::select! {
                r = &mut plan_run => break r,
                Some(h) = hrx.recv() => {
                    handed_so_far.push(h.clone());
                    progress(Event::Goal(h));
                }
                Some(done) = tasks.join_next() => {
                    let why = match done {
                        Ok(Ok(who)) => NavError::Config(format!("the {who} stopped before the run ended")),
                        Ok(Err(e)) => e,
                        Err(e) => NavError::Config(format!("a client task failed: {e}")),
                    };
                    break Err(why);
                }
                _ = tick.tick() => {
                    let (now, pose, travelled_mm) = pose_of(&world);
                    if travelled_mm - moved.1 >= 500.0 {
                        moved = (now, travelled_mm);
                    }
                    failure = if Duration::from_millis(now - t0) > cfg.limit {
                        Some(format!(
                            "the robot did not arrive within {} of simulated time",
                            minutes(cfg.limit)
                        ))
                    } else if Duration::from_millis(now - moved.0) > cfg.stuck {
                        Some(format!(
                            "the robot is stuck at ({:.1}, {:.1}) m: it has moved less than half a metre in {} of simulated time",
                            pose.x / 1_000.0,
                            pose.y / 1_000.0,
                            minutes(cfg.stuck)
                        ))
                    } else {
                        None
                    };
                    if failure.is_some() {
                        // The goal in hand when the run was given up was
                        // not completed.
                        handed_so_far.pop();
                        break Ok(std::mem::take(&mut handed_so_far));
                    }
                    progress(Event::Tick { time_s: (now - t0) as f64 / 1_000.0, pose, travelled_mm });
                }
            }
        }
    };
    let (end_ms, end, travelled) = pose_of(&world);
    drop(stepper);
    let trail: Vec<Point> = world
        .lock()
        .robot(index)
        .trail
        .iter()
        .map(|p| (p.x, p.y))
        .collect();
    let plates = read_all(&pboard, crate::board::Var::Plate).await;
    let fixes = read_all(&pboard, crate::board::Var::HeadingFix).await;
    tasks.abort_all();
    while tasks.join_next().await.is_some() {}
    rig.stop().await;
    let handed = outcome?;

    let mut nav = NavLog::default();
    while let Ok(n) = nav_rx.try_recv() {
        nav = n;
    }
    let mut lights = Vec::new();
    while let Ok(s) = seg_rx.try_recv() {
        lights.push(s);
    }
    let last_heading = plan
        .route
        .legs()
        .last()
        .map_or(plan.start_heading_deg, |l| l.3);
    let d = direction(last_heading);
    let (dx, dy) = (end.x - goal.0, end.y - goal.1);
    let mut done = ModeCount::default();
    for h in &handed {
        match h.step.goal.goal_type {
            crate::board::GoalType::L => done.l += 1,
            crate::board::GoalType::C => done.c += 1,
            crate::board::GoalType::D => done.d += 1,
            crate::board::GoalType::E => {}
        }
    }
    Ok(Report {
        from: cfg.from.clone(),
        to: cfg.to.clone(),
        modes_needed: plan.modes(),
        modes_done: done,
        plan,
        driven_m: travelled / 1_000.0,
        to_goal_cm: (dx * d.0 + dy * d.1) / 10.0,
        off_line_cm: (dx * d.1 - dy * d.0).abs() / 10.0,
        miss_cm: distance((end.x, end.y), goal) / 10.0,
        run_time: Duration::from_millis(end_ms - t0),
        wall_time: wall.elapsed(),
        trail,
        nav,
        lights,
        plates,
        fixes,
        failure,
    })
}

/// How near the goal a run must end to have arrived, cm (the end-to-end
/// tests' bound).
pub const ARRIVED_CM: f64 = 100.0;

/// `3 min` or `90 s`.
fn minutes(d: Duration) -> String {
    let s = d.as_secs();
    if s.is_multiple_of(60) {
        format!("{} min", s / 60)
    } else {
        format!("{s} s")
    }
}

/// Every value a variable's history holds, oldest first.
async fn read_all<T: serde::de::DeserializeOwned>(board: &Board, var: crate::board::Var) -> Vec<T> {
    let name = board.var_name(var);
    let ds = board.client();
    let Ok(info) = ds.history(&name).await else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for back in (0..info.stored).rev() {
        if let Ok(v) = ds.get_back(&name, back).await {
            if let Ok(t) = serde_json::from_value(v) {
                out.push(t);
            }
        }
    }
    out
}

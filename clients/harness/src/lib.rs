//! Whole runs in one process (`rome demo`): one data server, one simulated
//! world with any number of robots, each robot's hardware servers and its
//! five navigation clients, all on one in-process Zenoh session. Every
//! robot has its own blackboard (`nav/<robot>/…`) on the one data server,
//! and they drive at the same time. The result is a row of Table 6.1 per
//! robot, judged by ground truth, and one picture of every trajectory.
//!
//! How this crate is laid out: [`Harness`] starts the servers and the
//! simulated world; [`run`] and [`run_fleet`] add each robot's crew
//! (`rome_nav::crew`) and judge the run with `rome-nav`'s `report` module,
//! telling whoever watches through [`events`]; [`routes`] reads and picks
//! the robots' routes; [`tasks`] gives a fleet errands through the
//! dispatcher instead of routes, and [`scale`] measures fleets of
//! several sizes so (`rome fleet`);
//! [`experiment`] reruns Chapter 6's runs many at a time and tabulates
//! them beside the thesis' (`rome experiment`); [`confidence`] is §6.3's
//! automaton, its probabilities estimated from those runs. It
//! is kept apart from `rome-nav` so the navigation clients depend on the
//! data and hardware servers' protocol only, never on the servers or the
//! simulator.

use rome_client::net::NetOptions;
use rome_client::sim::TruthClient;
use rome_client::{DataClient, DataOptions, RobotClient, RobotOptions};
use rome_maps::geometry::Point;
use rome_maps::{Map, Network, World};
use rome_nav::board::{Board, Var};
use rome_nav::crew::{Member, Reports};
use rome_nav::ctracker::TrackConfig;
use rome_nav::himm::HimmConfig;
use rome_nav::navigator::{NavConfig, NavLog};
use rome_nav::plan::Plan;
use rome_nav::planner::{self, Handed, Progress};
use rome_nav::plfinder::PlConfig;
use rome_nav::report::{Ended, Report};
use rome_nav::traffic::Rules;
use rome_nav::NavError;
use rome_schema::Root;
use rome_sim::{Noise, Pose};
use rome_sim_hardware::world::SimWorld;
use std::time::{Duration, Instant};
use tokio::sync::mpsc;
use tracing::Instrument;

/// The span a robot's crew runs in: crews share one process, and their
/// log lines carry the robot's name. At the error level, so that a filter
/// that lets through only the navigation clients' lines
/// (`RUST_LOG=warn,rome_nav::navigator=debug`) still names the robot of
/// each: a span below the filter's level is not entered, and its lines go
/// out unnamed.
pub(crate) fn crew_span(robot: &str) -> tracing::Span {
    tracing::error_span!("crew", robot = %robot)
}

pub mod confidence;
pub mod events;
pub mod experiment;
pub mod floors;
pub mod plates;
pub mod rig;
pub mod routes;
pub mod scale;
pub mod tasks;

pub use events::{Event, FleetReport, PartState, RobotTick};
pub use rig::Harness;
pub use rome_nav::report::ARRIVED_CM;
pub use routes::{parse_routes, pick_routes, RouteSpec};

/// What to run.
#[derive(Debug, Clone)]
pub struct RunConfig {
    /// The map.
    pub map: Map,
    /// A building of several floors instead of one map (`None`: the map):
    /// the world holds every floor and a car in every shaft, routes name
    /// `FLOOR:POSITION`, and starts are on the world's plane
    /// ([`rome_maps::plane::Plane`]).
    pub building: Option<rome_maps::building::Building>,
    /// Each robot's route, in order (robot k's colour and row).
    pub routes: Vec<RouteSpec>,
    /// Seed of the simulated world.
    pub seed: u64,
    /// Sensor noise and wheel slip.
    pub noise: Noise,
    /// Lock-step (the default): the world takes a step only when every
    /// server and client of the run has finished with the present instant,
    /// so a seed gives the same run whatever the machine's load. Otherwise
    /// the world is paced against the wall clock at `speed` and the
    /// clients keep up as they can.
    pub lockstep: bool,
    /// Simulated time per real time: the pace in a run against the wall
    /// clock, the most a lock-step run may go (`None`: as fast as the
    /// clients compute; a run against the wall clock then goes at 4 ×).
    pub speed: Option<f64>,
    /// Give up after this much simulated time.
    pub limit: Duration,
    /// Give up on a robot that has not moved half a metre in this much
    /// simulated time (pinned against a wall, say).
    pub stuck: Duration,
    /// A robot taking tasks gives one up as overdue after driving its
    /// route's length at this speed, mm/s, plus two minutes.
    pub slowest_mm_s: f64,
    /// How the Navigator drives.
    pub nav: NavConfig,
    /// How the CTracker tracks.
    pub track: TrackConfig,
    /// Whether the local mapper corrects the odometry.
    pub himm: bool,
    /// How the local mapper corrects.
    pub himm_cfg: HimmConfig,
    /// Whether the plate finder looks for door plates.
    pub plfinder: bool,
    /// Robots whose upward camera is covered: they see no light.
    pub covered: Vec<String>,
    /// People walking to and fro along the corridors, placed with the seed
    /// (the thesis' robot met them in the hallways).
    pub people: usize,
    /// The rules the robots drive by (`rome_nav::traffic::Rules`): all
    /// off but standing apart, as there.
    pub rules: Rules,
    /// The network of the run's session: by default it talks to nobody
    /// else; with endpoints, `rome view`, `rome echo` or `rome record` in
    /// other processes can watch.
    pub net: NetOptions,
    /// Write the world's ground truth at every instant to this file
    /// (`rome_sim_hardware::trace`), to compare two runs bit for bit.
    pub trace: Option<std::path::PathBuf>,
}

impl RunConfig {
    /// The route network every robot of the run plans on: the map's, with
    /// its narrow corridors on loops one way if `one_way` of [`RunConfig::rules`].
    fn network(&self, world: &World) -> Network {
        rome_nav::traffic::oneway::network(&self.map, world, self.rules.one_way)
    }

    /// The wall-clock pace of a run that is not lock-step.
    pub fn wall_speed(&self) -> f64 {
        self.speed.unwrap_or(DEFAULT_WALL_SPEED)
    }

    /// A period of `ms` simulated milliseconds as the servers' and
    /// monitor's clocks count it.
    pub(crate) fn period(&self, ms: f64) -> Duration {
        if self.lockstep {
            Duration::from_secs_f64(ms / 1_000.0)
        } else {
            Duration::from_secs_f64((ms / 1_000.0 / self.wall_speed()).max(0.002))
        }
    }

    /// One robot, `r1`, on `map` with the defaults: noise on, 4 × real time.
    pub fn new(map: Map, from: &str, to: &str) -> RunConfig {
        RunConfig::fleet(map, vec![RouteSpec::new("r1", from, to)])
    }

    /// Several robots, one route each.
    pub fn fleet(map: Map, routes: Vec<RouteSpec>) -> RunConfig {
        RunConfig {
            map,
            building: None,
            routes,
            seed: 1,
            noise: Noise::default(),
            lockstep: true,
            speed: None,
            limit: Duration::from_secs(3_600),
            stuck: Duration::from_secs(180),
            slowest_mm_s: 100.0,
            nav: NavConfig::default(),
            track: TrackConfig::default(),
            himm: true,
            himm_cfg: HimmConfig::default(),
            plfinder: true,
            covered: Vec::new(),
            people: 0,
            rules: Rules::default(),
            net: NetOptions::isolated(),
            trace: None,
        }
    }
}

/// Simulated time per real time of a run against the wall clock with no
/// speed given.
pub const DEFAULT_WALL_SPEED: f64 = 4.0;

/// Each robot's start: its plan's first point, facing along the route.
pub fn starts(plans: &[(String, Plan)]) -> Vec<(String, Pose)> {
    plans
        .iter()
        .map(|(robot, plan)| {
            let (start, _) = plan.ends();
            (
                robot.clone(),
                Pose::new(start.x, start.y, plan.start_heading_deg),
            )
        })
        .collect()
}

/// The members of a robot's crew as `cfg` has them, the Navigator at
/// `cruise_mm_s` if given.
pub fn members(cfg: &RunConfig, world: &World, cruise_mm_s: Option<f64>) -> Vec<Member> {
    let mut nav_cfg = cfg.nav.clone();
    if let Some(v) = cruise_mm_s {
        nav_cfg.cruise_mm_s = v;
    }
    let mut members = vec![
        Member::Navigator(nav_cfg),
        Member::CTracker(cfg.track.clone()),
    ];
    if cfg.himm {
        members.push(Member::Mapper(cfg.himm_cfg.clone()));
    }
    if cfg.plfinder {
        members.push(Member::PlFinder(PlConfig::with_map(world)));
    }
    members
}

/// Runs one robot from its start to its goal; `progress` hears what
/// happens.
pub async fn run(cfg: RunConfig, mut progress: impl FnMut(Event)) -> Result<Report, NavError> {
    if cfg.routes.len() != 1 {
        return Err(NavError::Config(format!(
            "run() drives one robot; {} routes given (use run_fleet)",
            cfg.routes.len()
        )));
    }
    let mut fleet = run_fleet(cfg, &mut progress).await?;
    fleet
        .robots
        .pop()
        .ok_or(NavError::Gone("the run ended without a report"))
}

/// One robot's clients, connected and ready.
struct Crew {
    k: usize,
    name: String,
    from: String,
    to: String,
    plan: Plan,
    board: Board,
    robot: RobotClient,
    truth: TruthClient,
    world_index: usize,
}

/// Opens the clients of one role for robot `robot`.
pub async fn connect(
    session: &zenoh::Session,
    robot: &str,
    role: &'static str,
) -> Result<(Board, RobotClient), NavError> {
    let ds = DataClient::connect(session, DataOptions::new(role)).await?;
    let rc = RobotClient::connect(session, robot, RobotOptions::new(role)).await?;
    Ok((Board::new(ds, robot), rc))
}

/// Runs every robot of `cfg` at once; `progress` hears what happens.
pub async fn run_fleet(
    cfg: RunConfig,
    progress: &mut impl FnMut(Event),
) -> Result<FleetReport, NavError> {
    let lockstep = cfg.lockstep;
    monitored(lockstep, |clock| run_all(cfg, progress, clock)).await
}

/// Runs `run` as the run's monitor: in lock-step (`lockstep`) it is handed
/// the clock the world will step by, and everything it starts, servers and
/// clients, is a participant of that clock; otherwise it is handed none.
pub async fn monitored<F, Fut, T>(lockstep: bool, run: F) -> T
where
    F: FnOnce(Option<rome_clock::LockStep>) -> Fut,
    Fut: std::future::Future<Output = T>,
{
    if lockstep {
        let clock = rome_clock::LockStep::new(0);
        clock
            .clone()
            .participate("the run's monitor", run(Some(clock)))
            .await
    } else {
        run(None).await
    }
}

async fn run_all(
    cfg: RunConfig,
    progress: &mut impl FnMut(Event),
    clock: Option<rome_clock::LockStep>,
) -> Result<FleetReport, NavError> {
    let wall = Instant::now();
    if cfg.routes.is_empty() {
        return Err(NavError::Config("no robots to run".into()));
    }
    let world_map = World::from_map(&cfg.map);
    let network = cfg.network(&world_map);
    let mut plans = Vec::new();
    for (k, r) in cfg.routes.iter().enumerate() {
        if cfg.routes[..k].iter().any(|o| o.robot == r.robot) {
            return Err(NavError::Config(format!(
                "two routes for robot '{}'",
                r.robot
            )));
        }
        let plan = Plan::through(&world_map, &network, &r.from, &r.via, &r.to)?.keeping(&cfg.rules);
        progress(Event::Planned {
            robot: k,
            plan: plan.clone(),
        });
        plans.push((r.robot.clone(), plan));
    }
    let rig = Harness::start(&cfg, &starts(&plans), cfg.net.clone()).await?;
    let session = rig.session.clone();
    let root = Root::default();

    // Everyone's clients are up before the world steps, so each run's
    // clock starts with its robot at its start.
    let mut crews = Vec::new();
    let mut tasks = tokio::task::JoinSet::new();
    let (nav_tx, mut nav_rx) = mpsc::unbounded_channel::<(usize, NavLog)>();
    for (k, (name, plan)) in plans.iter().enumerate() {
        let (board, robot) = connect(&session, name, "planner").await?;
        let truth = TruthClient::new(&session, &root, name)?;
        for member in members(&cfg, &world_map, cfg.routes[k].cruise_mm_s) {
            let role = member.role();
            let (board, robot) = connect(&session, name, role).await?;
            let mut reports = Reports::default();
            if let Member::Navigator(_) = member {
                let (ntx, mut nrx) = mpsc::unbounded_channel::<NavLog>();
                let fwd = nav_tx.clone();
                tokio::spawn(async move {
                    while let Some(log) = nrx.recv().await {
                        let _ = fwd.send((k, log));
                    }
                });
                reports.nav = Some(ntx);
            }
            let span = crew_span(name);
            tasks.spawn(rome_clock::wrap(
                &format!("{name} {role}"),
                async move {
                    let r = member.run(robot, board, reports).await;
                    (k, r.map(|_| role))
                }
                .instrument(span),
            ));
        }
        crews.push(Crew {
            k,
            name: name.clone(),
            from: cfg.routes[k].from.clone(),
            to: cfg.routes[k].to.clone(),
            plan: plan.clone(),
            board,
            robot,
            truth,
            world_index: rig.index[k],
        });
    }
    drop(nav_tx);
    progress(Event::Started {
        session: session.clone(),
    });
    rig.trace(cfg.trace.as_deref())?;
    let stepper = match clock {
        Some(clock) => rig.world.start_lockstep(clock, cfg.speed, |_| {}),
        None => rig.world.start(Some(cfg.wall_speed())),
    };

    // Each robot's Planner runs in a task of its own; a robot whose client
    // fails, or that is stuck or late, ends alone and the others go on.
    let (etx, mut erx) = mpsc::unbounded_channel::<Event>();
    let mut drivers = tokio::task::JoinSet::new();
    let mut cancels = Vec::new();
    for crew in crews {
        let (cancel, cancelled) = tokio::sync::oneshot::channel::<String>();
        cancels.push(Some(cancel));
        let etx = etx.clone();
        let name = format!("{} planner", crew.name);
        drivers.spawn(rome_clock::wrap(
            &name,
            drive(crew, rig.world.clone(), wall, etx, cancelled),
        ));
    }
    drop(etx);

    let n = cfg.routes.len();
    let mut reports: Vec<Option<Report>> = vec![None; n];
    let mut navs = vec![NavLog::default(); n];
    let mut max_err = vec![0.0f64; n];
    // Odometry means something only once the Planner has registered the
    // robot at its start, just before handing over the first goal.
    let mut registered = vec![false; n];
    // Robots stopped in a corridor, waiting for a junction or passage to
    // be free: waiting their turn is not being stuck.
    let mut waiting = vec![false; n];
    let mut moved: Vec<(u64, f64)> = vec![(0, 0.0); n];
    let t0 = rig.world.lock().time_ms();
    let monitors: Vec<RobotClient> = {
        let mut m = Vec::new();
        for (name, _) in &plans {
            m.push(RobotClient::connect(&session, name, RobotOptions::new("monitor")).await?);
        }
        m
    };
    for m in moved.iter_mut() {
        m.0 = t0;
    }
    let mut tick = rome_clock::interval(cfg.period(1_000.0));
    while reports.iter().any(Option::is_none) {
        tokio::select! {
            biased;
            Some(event) = rome_clock::idle(erx.recv()) => {
                match &event {
                    Event::Finished { robot, report } => reports[*robot] = Some((**report).clone()),
                    Event::Goal { robot, .. } => registered[*robot] = true,
                    Event::Traffic { robot, state, .. } => {
                        waiting[*robot] = *state == PartState::Waiting;
                    }
                    _ => {}
                }
                progress(event);
            }
            Some(done) = tasks.join_next() => {
                let (k, why) = match done {
                    Ok((k, Ok(who))) => (k, format!("the {who} stopped before the run ended")),
                    Ok((k, Err(e))) => (k, format!("a navigation client failed: {e}")),
                    Err(e) => {
                        // A panicked client task: its robot is unknown, so
                        // every robot still running is given up.
                        let why = format!("a client task failed: {e}");
                        for c in cancels.iter_mut() {
                            if let Some(c) = c.take() {
                                let _ = c.send(why.clone());
                            }
                        }
                        continue;
                    }
                };
                if let Some(c) = cancels[k].take() {
                    let _ = c.send(why);
                }
            }
            Some(_) = drivers.join_next() => {}
            Some((k, log)) = rome_clock::idle(nav_rx.recv()) => navs[k] = log,
            _ = tick.tick() => {
                let mut robots = Vec::with_capacity(n);
                let now = rig.world.lock().time_ms();
                for k in 0..n {
                    let (pose, travelled_mm) = {
                        let sim = rig.world.lock();
                        let r = sim.robot(rig.index[k]);
                        (r.pose, r.travelled_mm)
                    };
                    let finished = reports[k].is_some();
                    let mut odometry_error_mm = 0.0;
                    if !finished {
                        let pose_now = if registered[k] { monitors[k].pose().await.ok() } else { None };
                        if let Some(p) = pose_now {
                            odometry_error_mm = Pose::from(&p).dist(&pose);
                            max_err[k] = max_err[k].max(odometry_error_mm);
                        }
                        if travelled_mm - moved[k].1 >= 500.0 || waiting[k] {
                            moved[k] = (now, travelled_mm);
                        }
                        let why = if Duration::from_millis(now - t0) > cfg.limit {
                            Some(format!(
                                "the robot did not arrive within {} of simulated time",
                                minutes(cfg.limit)
                            ))
                        } else if Duration::from_millis(now - moved[k].0) > cfg.stuck {
                            Some(format!(
                                "the robot is stuck at ({:.1}, {:.1}) m: it has moved less than half a metre in {} of simulated time",
                                pose.at.x / 1_000.0,
                                pose.at.y / 1_000.0,
                                minutes(cfg.stuck)
                            ))
                        } else {
                            None
                        };
                        if let Some(why) = why {
                            if let Some(c) = cancels[k].take() {
                                let _ = c.send(why);
                            }
                        }
                    }
                    robots.push(RobotTick { pose, travelled_mm, odometry_error_mm, finished });
                }
                progress(Event::Tick { time_s: (now - t0) as f64 / 1_000.0, robots });
            }
        }
    }
    drop(stepper);
    tasks.abort_all();
    while tasks.join_next().await.is_some() {}
    drivers.abort_all();
    while drivers.join_next().await.is_some() {}
    let mut robots = Vec::with_capacity(n);
    for (k, r) in reports.into_iter().enumerate() {
        let Some(mut r) = r else { continue };
        r.nav = navs[k].clone();
        r.odometry_max_error_cm =
            Some(max_err[k].max(r.odometry_error_cm.unwrap_or(0.0) * 10.0) / 10.0);
        r.trail = rig
            .world
            .lock()
            .robot(rig.index[k])
            .trail
            .iter()
            .map(|p| p.at)
            .collect::<Vec<Point>>();
        robots.push(r);
    }
    rig.stop().await;
    Ok(FleetReport {
        robots,
        wall_time: wall.elapsed(),
    })
}

/// One robot's run: puts it down, hands its goals over and judges them,
/// until it is done, fails, or is cancelled with a reason. Sends
/// [`Event::Finished`] with its report in every case.
async fn drive(
    crew: Crew,
    world: SimWorld,
    wall: Instant,
    events: mpsc::UnboundedSender<Event>,
    cancelled: tokio::sync::oneshot::Receiver<String>,
) {
    let k = crew.k;
    let start = rome_sim_hardware::truth::truth_of(&world, crew.world_index);
    // Goals judged so far: a run given up still shows the modes it got to.
    let mut judged: Vec<Handed> = Vec::new();
    let failure = {
        let run = async {
            planner::put_down(&crew.robot, &crew.plan, None).await?;
            planner::run(&crew.board, &crew.plan, Some(&crew.truth), |p| {
                let event = match p {
                    Progress::Handed(h) => Event::Goal {
                        robot: k,
                        handed: h.clone(),
                    },
                    Progress::Done(h) => {
                        judged.push(h.clone());
                        Event::Judged {
                            robot: k,
                            handed: h.clone(),
                        }
                    }
                    Progress::Waiting(part) => Event::Traffic {
                        robot: k,
                        part: part.to_string(),
                        state: PartState::Waiting,
                    },
                    Progress::Holding(part, holding) => Event::Traffic {
                        robot: k,
                        part: part.to_string(),
                        state: if holding {
                            PartState::Holding
                        } else {
                            PartState::Left
                        },
                    },
                };
                let _ = events.send(event);
            })
            .await
        };
        tokio::select! {
            biased;
            r = run => r.err().map(|e| format!("the Planner stopped: {e}")),
            why = cancelled => Some(why.unwrap_or_else(|_| "the run was stopped".into())),
        }
    };
    // A robot whose run ended stands still, so it does not drive on into
    // the others, and gives back what it held of the building, so they
    // are not kept waiting for it (a run given up ends holding what it
    // held at that moment).
    let _ = crew.robot.stop(false).await;
    if let Err(e) = planner::give_back_all(&crew.board).await {
        tracing::warn!(robot = %crew.name, error = %e, "could not give back what the robot held");
    }
    let end = rome_sim_hardware::truth::truth_of(&world, crew.world_index);
    let odometry = crew.robot.pose().await.ok().map(|p| Pose::from(&p).at);
    // Its Navigator is told to stop too, or it drives on to the goal at
    // hand when it next steers, into the robots that go on.
    if failure.is_some()
        && !matches!(
            planner::stop_navigator(&crew.board, &crew.robot).await,
            Ok(true)
        )
    {
        tracing::warn!(robot = %crew.name, "the Navigator did not take its stop");
    }
    let mut report = Report::new(Ended {
        robot: crew.name.clone(),
        from: crew.from.clone(),
        to: crew.to.clone(),
        plan: crew.plan.clone(),
        steps: judged,
        truth: (start, end),
        odometry,
        odometry_max_error_mm: None,
        wall_time: wall.elapsed(),
        failure,
    });
    report.people = world
        .lock()
        .walkers()
        .iter()
        .map(|w| (w.from, w.to))
        .collect();
    report.plates = read_all(&crew.board, Var::Plate).await;
    report.fixes = read_all(&crew.board, Var::HeadingFix).await;
    let _ = events.send(Event::Finished {
        robot: k,
        report: Box::new(report),
    });
}

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
async fn read_all<T: serde::de::DeserializeOwned>(board: &Board, var: Var) -> Vec<T> {
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

#[cfg(test)]
mod tests;

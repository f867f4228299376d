//! `rome bench robot`: round trips to the hardware servers of a simulated
//! robot (pose, sonar, three camera rows in one request) beside a bare
//! Zenoh queryable in the same run, the sustained scan-stream rate, and a
//! scan's age when it reaches a subscriber (from the sonar ring's reading,
//! stamped by the server, to the subscriber's hands).

use crate::bench::data::Row;
use rome_client::net::{open_loopback_peer, NetOptions};
use rome_client::{RobotClient, RobotOptions};
use rome_hardware::robot::Rates;
use rome_schema::Root;
use rome_sim::{Sim, SimConfig};
use rome_sim_hardware::robot::spawn_sim_robot;
use rome_sim_hardware::world::SimWorld;
use serde::Serialize;
use std::time::{Duration, Instant};
use zenoh::Wait;

/// Flags of `rome bench robot`.
#[derive(Debug, clap::Args)]
pub struct RobotBench {
    /// Seconds to measure each operation.
    #[arg(long, default_value_t = 2.0)]
    pub seconds: f64,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
}

/// The benchmark's figures.
#[derive(Debug, Clone, Serialize)]
pub struct RobotFigures {
    /// Round trips, one client, one request at a time.
    pub rows: Vec<Row>,
    /// Scans received per second with the world free-running.
    pub scans_per_s: f64,
    /// Scans missing from the sequence numbers while measuring.
    pub scans_lost: u64,
}

const RAW_KEY: &str = "rome-bench/raw-robot";
/// The pose of the benchmark's robot, under the default root.
const POSE_KEY: &str = "rome/robot/r1/base/pose";

/// The round trips measured, one request at a time.
#[derive(Debug, Clone, Copy)]
enum Probe {
    /// The bare queryable, the reference.
    Raw,
    /// `base/pose` by a plain Zenoh get, its reply not decoded: the
    /// server's part of a pose, without the client library's.
    PlainPose,
    Pose,
    Sonar,
    Rows,
}

impl Probe {
    const ALL: [Probe; 5] = [
        Probe::Raw,
        Probe::PlainPose,
        Probe::Pose,
        Probe::Sonar,
        Probe::Rows,
    ];

    fn name(self) -> &'static str {
        match self {
            Probe::Raw => "zenoh-queryable",
            Probe::PlainPose => "pose-plain-get",
            Probe::Pose => "pose",
            Probe::Sonar => "sonar",
            Probe::Rows => "camera-3-rows",
        }
    }

    async fn once(self, session: &zenoh::Session, r: &RobotClient) -> anyhow::Result<()> {
        match self {
            Probe::Raw | Probe::PlainPose => {
                let key = match self {
                    Probe::Raw => RAW_KEY,
                    _ => POSE_KEY,
                };
                let replies = session.get(key).await.map_err(|e| anyhow::anyhow!("{e}"))?;
                replies
                    .recv_async()
                    .await
                    .map_err(|e| anyhow::anyhow!("no reply on {key}: {e}"))?
                    .result()
                    .map_err(|_| anyhow::anyhow!("an error reply on {key}"))?;
            }
            Probe::Pose => {
                r.pose().await?;
            }
            Probe::Sonar => {
                r.sonar().await?;
            }
            Probe::Rows => {
                r.camera_rows("up", &[120, 241, 360]).await?;
            }
        }
        Ok(())
    }
}

/// Runs the benchmark.
pub async fn figures(args: &RobotBench, progress: bool) -> anyhow::Result<RobotFigures> {
    anyhow::ensure!(
        args.seconds.is_finite() && args.seconds > 0.0,
        "--seconds must be positive"
    );
    let span = Duration::from_secs_f64(args.seconds);
    let (server, port) = open_loopback_peer(&[]).await?;
    let _raw = server
        .declare_queryable(RAW_KEY)
        .callback(|q| {
            let _ = q.reply(RAW_KEY, b"0".to_vec()).wait();
        })
        .await
        .map_err(|e| anyhow::anyhow!("{e}"))?;
    let map = rome_maps::load_named("fig5_3")?;
    let mut sim = Sim::new(&map, SimConfig::default());
    let heading = sim
        .scene()
        .world
        .position("301L")
        .map_or(0.0, |p| p.wall_heading_deg);
    sim.add_robot_at("r1", "301L", heading)?;
    let world = SimWorld::new(sim);
    // Round trips are measured with the world at real time, as `rome sim`
    // runs it; the scan stream below, with the world running flat out.
    let stepper = world.start(Some(1.0));
    let rates = Rates {
        state: Some(Duration::from_millis(100)),
        scan: Some(Duration::from_millis(1)),
        camera: Duration::from_millis(500),
    };
    let servers = spawn_sim_robot(&server, &Root::default(), &world, "r1", rates)?;
    let session = NetOptions::loopback_client(port).open().await?;
    let r = RobotClient::connect(&session, "r1", RobotOptions::new("bench")).await?;
    // The servers are up once a pose comes back.
    let up = Instant::now();
    while r.pose().await.is_err() {
        anyhow::ensure!(
            up.elapsed() < Duration::from_secs(10),
            "servers did not start"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
    let bar = std::cell::RefCell::new(
        progress.then(|| rome_common::progress::Progress::counter("bench robot", "measurements")),
    );
    let done = std::cell::Cell::new(0u64);
    let say = |what: &str| {
        if let Some(b) = bar.borrow_mut().as_mut() {
            b.step(done.get(), what);
        }
        done.set(done.get() + 1);
    };
    for p in Probe::ALL {
        let warm = Instant::now();
        while warm.elapsed() < span / 20 {
            p.once(&session, &r).await?;
        }
    }
    let (session, robot) = (&session, &r);
    let taken = crate::bench::data::in_turns(Probe::ALL.len(), span, say, |k, slice| async move {
        let p = Probe::ALL[k];
        let started = Instant::now();
        let mut lat = Vec::new();
        while started.elapsed() < slice {
            let t = Instant::now();
            p.once(session, robot).await?;
            lat.push(t.elapsed().as_micros() as u64);
        }
        Ok((lat, started.elapsed()))
    })
    .await?;
    let mut rows = Vec::new();
    for (p, (lat, spent)) in Probe::ALL.into_iter().zip(taken) {
        rows.push(Row::from_latencies(p.name(), 1, lat, spent)?);
    }
    say("scan stream");
    drop(stepper);
    let stepper = world.start(None);
    let scans = r.scans().await?;
    let first = scans
        .next()
        .await
        .ok_or_else(|| anyhow::anyhow!("no scan"))??;
    let started = Instant::now();
    let mut last = first.seq;
    let mut got = 0u64;
    let mut ages = Vec::new();
    while started.elapsed() < span {
        match tokio::time::timeout(span, scans.next_stamped()).await {
            Ok(Some(Ok((s, at)))) => {
                got += 1;
                last = s.seq;
                if let Some(age) = at.and_then(|at| at.elapsed().ok()) {
                    ages.push(age.as_micros() as u64);
                }
            }
            _ => break,
        }
    }
    anyhow::ensure!(
        !ages.is_empty(),
        "no scan carried the time its sonar ring was read"
    );
    rows.push(Row::from_latencies(
        "scan read→sub",
        1,
        ages,
        started.elapsed(),
    )?);
    let elapsed = started.elapsed().as_secs_f64();
    let lost = (last - first.seq).saturating_sub(got);
    for s in servers {
        s.stop().await?;
    }
    drop(stepper);
    let _ = session.close().await;
    let _ = server.close().await;
    Ok(RobotFigures {
        rows,
        scans_per_s: got as f64 / elapsed,
        scans_lost: lost,
    })
}

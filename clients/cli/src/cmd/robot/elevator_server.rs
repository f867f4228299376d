//! `rome elevator-server`: the elevators of a building as simulated cars,
//! each with its server under `<root>/building/elevator/<name>/…`, until
//! Ctrl-C or SIGTERM.

use crate::args::CommonArgs;
use crate::exit;
use anyhow::Context;
use rome_hardware::elevator::spawn_elevator;
use rome_hardware::ServerConfig;
use rome_sim::elevator::{Car, CarSpec};
use rome_sim_hardware::elevator::SimCar;
use std::time::Duration;

/// Flags of `rome elevator-server`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The building: the built-in `tower`, or a .bldg file.
    #[arg(long, default_value = "tower", value_name = "BUILDING")]
    pub building: String,
    /// Serve only these elevators (default: all of the building's).
    #[arg(long, value_delimiter = ',', value_name = "NAME")]
    pub elevator: Vec<String>,
    /// Simulated time per real time (1 = real time).
    #[arg(long, default_value_t = 1.0)]
    pub speed: f64,
    /// Travel time from one floor to the next, seconds.
    #[arg(long, default_value_t = 4.0, value_name = "SECS")]
    pub per_floor: f64,
    /// Time the doors take to open or close, seconds.
    #[arg(long, default_value_t = 2.0, value_name = "SECS")]
    pub doors: f64,
    /// Time the doors stay open at a stop, seconds.
    #[arg(long, default_value_t = 10.0, value_name = "SECS")]
    pub dwell: f64,
    /// State stream rate, Hz of real time (0: off).
    #[arg(long, default_value_t = 10.0, value_name = "HZ")]
    pub state_hz: f64,
    /// Do not keep the sessions' records in a storage of this process
    /// (a router's storage keeps them instead).
    #[arg(long)]
    pub no_storage: bool,
}

fn ms(secs: f64, flag: &str) -> anyhow::Result<u64> {
    anyhow::ensure!(
        secs.is_finite() && (0.0..=3_600.0).contains(&secs),
        "{flag} must be 0 … 3600 seconds, got {secs}"
    );
    Ok((secs * 1_000.0).round() as u64)
}

/// Runs the cars and their servers.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.speed.is_finite() && args.speed > 0.0 && args.speed <= 1_000.0,
        "--speed must be a positive number up to 1000, got {}",
        args.speed
    );
    anyhow::ensure!(
        args.state_hz.is_finite() && (0.0..=1_000.0).contains(&args.state_hz),
        "--state-hz must be 0 … 1000, got {}",
        args.state_hz
    );
    let spec = CarSpec {
        per_floor_ms: ms(args.per_floor, "--per-floor")?.max(1),
        doors_ms: ms(args.doors, "--doors")?,
        dwell_ms: ms(args.dwell, "--dwell")?,
    };
    let building = rome_maps::load_building_named(&args.building)
        .with_context(|| format!("cannot load the building '{}'", args.building))?;
    let known: Vec<&str> = building
        .elevators
        .iter()
        .map(|e| e.number.as_str())
        .collect();
    for name in &args.elevator {
        anyhow::ensure!(
            known.contains(&name.as_str()),
            "the building '{}' has no elevator '{name}'; it has {}",
            building.name,
            known.join(", ")
        );
    }
    let root = common.root()?;
    let (session, net) = common.open_server().await?;
    let (storage_stop, storage_stopped) = tokio::sync::oneshot::channel::<()>();
    let storage = (!args.no_storage).then(|| {
        let (session, root) = (session.clone(), root.clone());
        let key = format!("{}/store/building/**", root.as_str());
        tokio::spawn(async move {
            rome_hardware::storage::run(session, &root, key, async move {
                let _ = storage_stopped.await;
            })
            .await
        })
    });
    let period = (args.state_hz > 0.0).then(|| Duration::from_secs_f64(1.0 / args.state_hz));
    let mut servers = Vec::new();
    let mut cars = Vec::new();
    let mut said = Vec::new();
    for e in &building.elevators {
        if !args.elevator.is_empty() && !args.elevator.contains(&e.number) {
            continue;
        }
        let floors: Vec<String> = e
            .floors
            .iter()
            .map(|&i| building.floors[i].name.clone())
            .collect();
        let car = Car::new(floors.clone(), &floors[0], spec)
            .map_err(|err| anyhow::anyhow!("elevator {}: {err}", e.number))?;
        let car = SimCar::new(car);
        cars.push(car.run(args.speed));
        let config = ServerConfig::elevator(&root, &e.number)?;
        servers.push(spawn_elevator(&session, config, car, period).await?);
        said.push(format!("{} (floors {})", e.number, floors.join(", ")));
    }
    eprintln!(
        "rome elevator-server: building '{}', {} (listen {:?}, connect {:?}); serving '{}/building/elevator/<name>/{{call,go,open,close,state,lock,unlock}}' and buttons on '…/press'; Ctrl-C to stop",
        building.name,
        said.join(", "),
        net.listen,
        net.connect,
        root.as_str()
    );
    exit::interrupted().await;
    for (server, _buttons) in servers {
        if let Err(e) = server.stop().await {
            eprintln!("rome elevator-server: {e}");
        }
    }
    for c in cars {
        c.abort();
    }
    let _ = storage_stop.send(());
    if let Some(task) = storage {
        let _ = task.await;
    }
    let _ = session.close().await;
    Ok(exit::OK)
}

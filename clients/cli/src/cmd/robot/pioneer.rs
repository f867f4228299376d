//! `rome pioneer`: the base and proximity servers of a Pioneer robot on a
//! serial line (P2OS/ARCOS), until Ctrl-C or SIGTERM.

use crate::args::{CommonArgs, Side};
use crate::exit;
use rome_hardware::base::Base;
use rome_hardware::proximity::Proximity;
use rome_hardware::robot::spawn;
use rome_hardware::serial::{P2os, P2osConfig};
use rome_hardware::ServerConfig;
use rome_schema::robot::Device;
use std::time::Duration;

/// Flags of `rome pioneer`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The serial device (/dev/ttyUSB0 …).
    #[arg(long, value_name = "PATH")]
    pub device: String,
    /// The robot's name in keys.
    #[arg(long, default_value = "r1")]
    pub robot: String,
    /// Baud rate.
    #[arg(long, default_value_t = 9600)]
    pub baud: u32,
    /// How long the robot may stay silent before clients get errors, ms.
    #[arg(long, default_value_t = 1000, value_name = "MS")]
    pub answer_timeout_ms: u64,
    /// Base state stream rate, Hz.
    #[arg(long, default_value_t = 10.0, value_name = "HZ")]
    pub state_hz: f64,
}

/// Runs the servers.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    anyhow::ensure!(
        args.state_hz.is_finite() && args.state_hz > 0.0 && args.state_hz <= 1000.0,
        "--state-hz must be 0 … 1000"
    );
    let root = common.root()?;
    let session = common.open(Side::Server).await?;
    let robot = P2os::start(P2osConfig {
        path: args.device.clone(),
        baud: args.baud,
        answer_timeout: Duration::from_millis(args.answer_timeout_ms),
    });
    let servers = vec![
        spawn(
            &session,
            ServerConfig::new(&root, &args.robot, Device::Base)?,
            Base::new(
                &args.robot,
                robot.clone(),
                Some(Duration::from_secs_f64(1.0 / args.state_hz)),
            ),
        ),
        spawn(
            &session,
            ServerConfig::new(&root, &args.robot, Device::Proximity)?,
            Proximity::new(&args.robot, robot, Some(Duration::from_millis(50))),
        ),
    ];
    eprintln!(
        "rome pioneer: {} at {} baud as robot '{}'; Ctrl-C to stop",
        args.device, args.baud, args.robot
    );
    exit::interrupted().await;
    for s in servers {
        s.stop().await?;
    }
    let _ = session.close().await;
    Ok(exit::OK)
}

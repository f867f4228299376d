//! `rome robot ROBOT <command>`: every hardware-server command from the
//! shell. Replies are printed as one JSON line, like `z_get` would show
//! them; streams print one line per message.

use crate::args::{CommonArgs, Side};
use crate::exit;
use anyhow::Context;
use rome_client::robot::{Image, Lock, Stream};
use rome_client::{RobotClient, RobotOptions};
use rome_schema::robot::SONARS;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Duration;

/// Flags of `rome robot`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The robot (r1, r2 …).
    pub robot: String,
    /// This client's priority at the servers, 0 (lowest) … 255.
    #[arg(long, short = 'p', default_value_t = rome_schema::robot::DEFAULT_PRIORITY)]
    pub priority: u8,
    /// How long a command may wait behind another client's lock, seconds.
    #[arg(long, default_value_t = 10.0, value_name = "SECS")]
    pub wait: f64,
    /// The command.
    #[command(subcommand)]
    pub command: RobotCmd,
}

/// A hardware-server command.
#[derive(Debug, clap::Subcommand)]
pub enum RobotCmd {
    /// Go a distance straight (mm; negative backwards), then stop.
    Move {
        /// Distance, mm.
        #[arg(allow_hyphen_values = true)]
        distance_mm: f64,
        /// Velocity, mm/s (negative: keep the setting).
        #[arg(long, default_value_t = -1.0, allow_hyphen_values = true)]
        velocity: f64,
        /// Acceleration, mm/s² (negative: keep the setting).
        #[arg(long, default_value_t = -1.0, allow_hyphen_values = true)]
        accel: f64,
    },
    /// Turn in place (degrees, positive clockwise).
    Turn {
        /// Angle, degrees.
        #[arg(allow_hyphen_values = true)]
        degrees: f64,
        /// Turn rate, °/s (negative: keep the setting).
        #[arg(long, default_value_t = -1.0, allow_hyphen_values = true)]
        velocity: f64,
        /// Turn acceleration, °/s² (negative: keep the setting).
        #[arg(long, default_value_t = -1.0, allow_hyphen_values = true)]
        accel: f64,
    },
    /// Go mode at a velocity (mm/s).
    Go {
        /// Velocity, mm/s.
        #[arg(allow_hyphen_values = true)]
        velocity_mm_s: f64,
    },
    /// Jog mode at a turn rate (°/s, positive clockwise).
    Jog {
        /// Turn rate, °/s.
        #[arg(allow_hyphen_values = true)]
        rate_deg_s: f64,
    },
    /// Stop: gradually, or at once with --emergency.
    Stop {
        /// Emergency stop.
        #[arg(long)]
        emergency: bool,
    },
    /// The pose in virtual 32-bit coordinates.
    Pose,
    /// Set the position registers.
    SetPose {
        /// x, mm.
        #[arg(allow_hyphen_values = true)]
        x_mm: i64,
        /// y, mm.
        #[arg(allow_hyphen_values = true)]
        y_mm: i64,
        /// Heading, degrees.
        #[arg(allow_hyphen_values = true)]
        heading_deg: f64,
    },
    /// Add to the position and heading.
    AdjustPose {
        /// Change of x, mm.
        #[arg(allow_hyphen_values = true)]
        dx_mm: i64,
        /// Change of y, mm.
        #[arg(allow_hyphen_values = true)]
        dy_mm: i64,
        /// Change of heading, degrees.
        #[arg(allow_hyphen_values = true)]
        dheading_deg: f64,
    },
    /// The bumper status.
    Bumper,
    /// Watch (stop on contact) or ignore the bumpers.
    SetBumper {
        /// watch or ignore.
        #[arg(value_parser = ["watch", "ignore"])]
        setting: String,
    },
    /// The velocity setting.
    Speed,
    /// The mean wheel speed.
    WheelSpeed,
    /// The operating mode.
    Mode,
    /// Hold the base's lock, printing the grant, until Ctrl-C or --hold runs out.
    Lock {
        /// Release after this many seconds (default: hold until Ctrl-C).
        #[arg(long, value_name = "SECS")]
        hold: Option<f64>,
    },
    /// Print the base's state stream.
    State {
        /// Stop after this many messages.
        #[arg(long, short = 'n')]
        count: Option<u64>,
    },
    /// The 24 sonar ranges, mm.
    Sonar,
    /// The 24 infrared values.
    Ir,
    /// Set the sonars' maximum range: one value for all, or 24.
    Timeout {
        /// mm, one or 24 values.
        #[arg(required = true, num_args = 1..=24)]
        max_mm: Vec<u32>,
    },
    /// Print the proximity scan stream.
    Scan {
        /// Stop after this many scans.
        #[arg(long, short = 'n')]
        count: Option<u64>,
    },
    /// A camera's commands (cameras: up, side).
    Camera {
        /// The camera.
        camera: String,
        /// What to do.
        #[command(subcommand)]
        command: CameraCmd,
    },
}

/// A camera-server command.
#[derive(Debug, clap::Subcommand)]
pub enum CameraCmd {
    /// The image size.
    Size,
    /// The last grabbed image: its header, or a PNG with -o.
    Grab {
        /// Write the image to this PNG file.
        #[arg(short, long, value_name = "FILE")]
        output: Option<PathBuf>,
    },
    /// Some rows of the last image, in one request (e.g. 120,241,360).
    Rows {
        /// Row numbers.
        #[arg(value_delimiter = ',', required = true)]
        rows: Vec<u32>,
    },
    /// Freeze the camera by holding its lock until Ctrl-C or --hold runs out.
    Lock {
        /// Release after this many seconds.
        #[arg(long, value_name = "SECS")]
        hold: Option<f64>,
    },
}

pub(super) fn print(value: &impl Serialize) -> anyhow::Result<()> {
    println!("{}", serde_json::to_string(value)?);
    Ok(())
}

/// Summarises an image reply; the pixels themselves go to a file.
fn describe(img: &Image) -> serde_json::Value {
    let mean = if img.pixels.is_empty() {
        0.0
    } else {
        img.pixels.iter().map(|p| f64::from(*p)).sum::<f64>() / img.pixels.len() as f64
    };
    serde_json::json!({
        "width": img.width, "height": img.height, "frame": img.frame,
        "time_ms": img.time_ms, "rows": img.rows.len(), "bytes": img.pixels.len(),
        "mean_gray": (mean * 10.0).round() / 10.0,
    })
}

/// Prints a stream's messages, `count` of them or until it ends.
pub(super) async fn follow<T: serde::de::DeserializeOwned + Serialize>(
    stream: Stream<T>,
    count: Option<u64>,
) -> anyhow::Result<()> {
    let mut seen = 0;
    while count.is_none_or(|c| seen < c) {
        match stream.next().await {
            Some(m) => print(&m?)?,
            None => break,
        }
        seen += 1;
    }
    Ok(())
}

pub(super) async fn hold(lock: Lock, secs: Option<f64>) -> anyhow::Result<u8> {
    print(lock.grant())?;
    match secs {
        Some(s) => {
            anyhow::ensure!(
                s.is_finite() && s >= 0.0,
                "--hold must be a number of seconds"
            );
            tokio::time::sleep(Duration::from_secs_f64(s)).await;
        }
        None => exit::interrupted().await,
    }
    let held = lock.held();
    lock.unlock().await?;
    anyhow::ensure!(held, "the lock was lost while held (a renewal was refused)");
    Ok(exit::OK)
}

/// A client session and the options of a one-command client at
/// `priority`, waiting at most `wait` seconds behind another's lock.
pub(super) async fn one_command(
    common: &CommonArgs,
    priority: u8,
    wait: f64,
) -> anyhow::Result<(zenoh::Session, RobotOptions)> {
    anyhow::ensure!(
        wait.is_finite() && wait >= 0.0,
        "--wait must be a number of seconds, got {wait}"
    );
    let session = common.open(Side::Client).await?;
    let mut options = RobotOptions::new("cli");
    options.root = common.root()?;
    options.priority = priority;
    options.queue_wait = Duration::from_secs_f64(wait);
    // `rome robot r1 go 300` starts the robot and exits: the base must not
    // take the exit for a dead controller.
    options.deadman = false;
    Ok((session, options))
}

/// Runs one robot command.
pub async fn run(common: &CommonArgs, args: Args) -> anyhow::Result<u8> {
    let (session, options) = one_command(common, args.priority, args.wait).await?;
    let r = RobotClient::connect(&session, &args.robot, options).await?;
    let what = || format!("robot '{}'", args.robot);
    match args.command {
        RobotCmd::Move {
            distance_mm,
            velocity,
            accel,
        } => print(
            &r.move_by(distance_mm, velocity, accel)
                .await
                .with_context(what)?,
        )?,
        RobotCmd::Turn {
            degrees,
            velocity,
            accel,
        } => print(&r.turn(degrees, velocity, accel).await.with_context(what)?)?,
        RobotCmd::Go { velocity_mm_s } => print(&r.go(velocity_mm_s).await.with_context(what)?)?,
        RobotCmd::Jog { rate_deg_s } => print(&r.jog(rate_deg_s).await.with_context(what)?)?,
        RobotCmd::Stop { emergency } => print(&r.stop(emergency).await.with_context(what)?)?,
        RobotCmd::Pose => print(&r.pose().await.with_context(what)?)?,
        RobotCmd::SetPose {
            x_mm,
            y_mm,
            heading_deg,
        } => print(
            &r.set_pose(x_mm, y_mm, heading_deg)
                .await
                .with_context(what)?,
        )?,
        RobotCmd::AdjustPose {
            dx_mm,
            dy_mm,
            dheading_deg,
        } => print(
            &r.adjust_pose(dx_mm, dy_mm, dheading_deg)
                .await
                .with_context(what)?,
        )?,
        RobotCmd::Bumper => print(&r.bumper().await.with_context(what)?)?,
        RobotCmd::SetBumper { setting } => {
            print(&r.set_bumper(setting == "watch").await.with_context(what)?)?
        }
        RobotCmd::Speed => print(&r.speed().await.with_context(what)?)?,
        RobotCmd::WheelSpeed => print(&r.wheel_speed().await.with_context(what)?)?,
        RobotCmd::Mode => print(&r.mode().await.with_context(what)?)?,
        RobotCmd::Lock { hold: secs } => {
            return hold(r.lock().await.with_context(what)?, secs).await
        }
        RobotCmd::State { count } => follow(r.state().await?, count).await?,
        RobotCmd::Sonar => print(&r.sonar().await.with_context(what)?)?,
        RobotCmd::Ir => print(&r.infrared().await.with_context(what)?)?,
        RobotCmd::Timeout { max_mm } => {
            let all: [u32; SONARS] = match max_mm.as_slice() {
                [one] => [*one; SONARS],
                many => many.try_into().map_err(|_| {
                    anyhow::anyhow!("give one range or {SONARS}, not {}", many.len())
                })?,
            };
            print(&r.set_timeout(all).await.with_context(what)?)?
        }
        RobotCmd::Scan { count } => follow(r.scans().await?, count).await?,
        RobotCmd::Camera { camera, command } => match command {
            CameraCmd::Size => print(&r.camera_size(&camera).await.with_context(what)?)?,
            CameraCmd::Grab { output } => {
                let img = r.camera_grab(&camera).await.with_context(what)?;
                if let Some(path) = output {
                    let gray =
                        image::GrayImage::from_raw(img.width, img.height, img.pixels.clone())
                            .context("the image's size does not match its pixels")?;
                    gray.save(&path)
                        .with_context(|| format!("cannot write {}", path.display()))?;
                    eprintln!("wrote {}", path.display());
                }
                print(&describe(&img))?
            }
            CameraCmd::Rows { rows } => {
                let img = r.camera_rows(&camera, &rows).await.with_context(what)?;
                let out: Vec<_> = img
                    .rows
                    .iter()
                    .enumerate()
                    .map(|(k, row)| serde_json::json!({"row": row, "pixels": img.row(k)}))
                    .collect();
                print(
                    &serde_json::json!({"frame": img.frame, "time_ms": img.time_ms, "width": img.width, "rows": out}),
                )?
            }
            CameraCmd::Lock { hold: secs } => {
                return hold(r.camera_lock(&camera).await.with_context(what)?, secs).await
            }
        },
    }
    Ok(exit::OK)
}

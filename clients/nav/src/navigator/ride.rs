//! Entering and exiting an elevator (§5.4.6), the Navigator's V goal:
//!
//! 0. take the elevator's session where the robot stands: robots take
//!    turns through it, and one waiting keeps off the door;
//! 1. *locate*: turn the side camera (it looks along sonar 18, to the
//!    left) to the door, back away from it if it is too near for the
//!    camera to hold the marker (a narrow corridor), and sweep about ±45°
//!    until a marker with the door's code is seen in the middle half of
//!    the image ([`crate::barcode`]); turn until it is straight abeam;
//! 2. *approach*: face the door and drive to [`APPROACH_MM`] from it;
//! 3. *wait*: call the car and wait until the front sonar sees into the
//!    cabin: sonar tells only whether the doors are open, as in the
//!    thesis;
//! 4. *enter* on infrared only: creep in until the forward detectors see
//!    the back wall (sonar inside a metal cabin is not to be trusted);
//! 5. *turn round* in place;
//! 6. *wait for the floor*: send the car on and wait until it stands at the
//!    floor with its doors open (the server says so: the thesis' human
//!    operator told the robot nothing either, but watched for it);
//! 7. *leave*: drive out to the corridor's line of lights, and give the
//!    session back.
//!
//! A marker that is not found, a car that does not come or does not
//! arrive within `wait_s`, an elevator server that stops answering end the
//! goal with the reason ([`NavError::Ride`]); the robot is stopped where
//! it is, and the session is given back (or, the server gone, freed when
//! it comes back and finds this client gone).

use super::*;
use crate::barcode::{self, ReaderConfig};
use crate::board::RideInfo;
use rome_client::elevator::ElevatorClient;
use rome_maps::marker::Code;
use rome_schema::elevator::Doors;
use rome_schema::robot::body::SIDE_FOV_DEG;

/// How far from the door (the front sonar's reading) the robot waits, mm.
pub const APPROACH_MM: f64 = 600.0;
/// How far from the door the side camera looks for the marker, at the
/// least, mm: nearer, its 50° do not hold the marker and its paper.
const VIEW_MM: f64 = 1_250.0;
/// How near the wall behind a robot that backs away from the door may
/// come, mm.
const BACK_CLEARANCE_MM: f64 = 250.0;
/// The sonars looking left (where the side camera looks) and right.
const LEFT: usize = 18;
const RIGHT: usize = 6;
/// The doors are open when the front sonar reads this much farther than
/// the door stood, mm (the cabin is two metres deep).
const OPEN_BEYOND_MM: f64 = 1_000.0;
/// Scans in a row that must see the doors open.
const OPEN_SCANS: u32 = 3;
/// How far either way the robot sweeps for the marker, and in what steps,
/// degrees.
const SWEEP_DEG: f64 = 45.0;
const SWEEP_STEP_DEG: f64 = 7.5;
/// How slowly it creeps into the cabin, mm/s.
const ENTER_MM_S: f64 = 150.0;
/// Speed of the approach and the way out, mm/s.
const MOVE_MM_S: f64 = 300.0;
/// Forward infrared slots looking 15° either side of ahead.
const IR_AHEAD: [usize; 2] = [1, 2];
/// The cabin's depth as far as a robot may creep, mm: farther means the
/// back wall was not seen.
const CABIN_MAX_MM: f64 = 2_400.0;
/// How far past the doors' line the robot's back must be before it turns
/// round, mm.
const INSIDE_MARGIN_MM: f64 = 100.0;
/// How often the car's state is asked while the robot waits for it.
const POLL: Duration = Duration::from_millis(500);

impl Navigator {
    /// Carries out a V goal: the ride in `Ride`.
    pub(super) async fn ride(
        &mut self,
        goal: &Goal,
        scans: &rome_client::robot::Stream<Scan>,
    ) -> Result<(), NavError> {
        let ride: RideInfo = self
            .board
            .get(Var::Ride)
            .await
            .map_err(|e| NavError::reading("the ride (Ride)", e))?;
        let code: Code = ride
            .marker
            .parse()
            .map_err(|e| NavError::Ride(format!("elevator {}: {e}", ride.elevator)))?;
        let wait = Duration::from_secs_f64(ride.wait_s.clamp(1.0, 3_600.0));
        // An elevator server gone or refusing ends the ride, not the
        // Navigator: the robot stops where it is, with the reason.
        let lift = |e: rome_client::ClientError| {
            NavError::Ride(format!("elevator {}: {e}", ride.elevator))
        };
        self.hallway = None;
        self.carry = None;
        self.send(Drive::Halt).await?;
        self.settle(scans).await?;

        // The session first: a robot waits its turn where it stands, off
        // the door, and looks for the marker once the doors are shut.
        let car = ElevatorClient::beside(&self.robot, &ride.elevator)
            .await
            .map_err(lift)?;
        let deadline = rome_clock::Instant::now() + wait;
        let session = self.take_session(&car, &ride, goal, deadline).await?;
        let done = self.ride_in_session(goal, &ride, code, &car, scans).await;
        // Given back whatever happened, before the Planner hears of it:
        // the next robot waits for it. A server that is gone frees it
        // when it comes back and finds this client gone.
        if let Err(e) = session.unlock().await {
            tracing::warn!(error = %e, "navigator: the elevator's session was not given back");
        }
        done
    }

    /// The ride once the robot holds the elevator's session.
    async fn ride_in_session(
        &mut self,
        goal: &Goal,
        ride: &RideInfo,
        code: Code,
        car: &ElevatorClient,
        scans: &rome_client::robot::Stream<Scan>,
    ) -> Result<(), NavError> {
        let wait = Duration::from_secs_f64(ride.wait_s.clamp(1.0, 3_600.0));
        let lift = |e: rome_client::ClientError| {
            NavError::Ride(format!("elevator {}: {e}", ride.elevator))
        };

        // 1. Locate the marker with the side camera.
        self.stage(goal, "elevator: locating the marker").await?;
        let heading = self.pose().await?.heading.deg();
        self.send(Drive::Turn(normalize_deg(
            goal.direction_deg - 90.0 - heading,
        )))
        .await?;
        let abeam = self.settle(scans).await?;
        // Too near the door for the camera to hold the marker and its
        // paper (a narrow corridor): back away from it, as far as the
        // wall behind allows.
        let near = f64::from(abeam.sonar_mm[LEFT]);
        let room = f64::from(abeam.sonar_mm[RIGHT]) - BACK_CLEARANCE_MM;
        let back = (VIEW_MM - near).min(room);
        if back > 50.0 {
            self.stage(goal, "elevator: backing away from the door")
                .await?;
            self.send(Drive::Turn(-90.0)).await?;
            self.settle(scans).await?;
            self.robot.move_by(back, MOVE_MM_S, -1.0).await?;
            self.last = None;
            self.settle(scans).await?;
            self.send(Drive::Turn(90.0)).await?;
            self.settle(scans).await?;
        }
        let (bearing, range) = self.sweep(code, 0.0, scans).await?.ok_or_else(|| {
            NavError::Ride(format!(
                "the marker {code} of elevator {} was not seen in a sweep of ±{SWEEP_DEG:.0}° about the door's bearing",
                ride.elevator
            ))
        })?;
        // 2. Face the door and come to APPROACH_MM of it.
        self.send(Drive::Turn(bearing + 90.0)).await?;
        let faced = self.settle(scans).await?;
        let ahead = f64::from(faced.sonar_mm[FORWARD]).min(range);
        self.stage(goal, "elevator: approaching the door").await?;
        if ahead - APPROACH_MM > 20.0 {
            self.robot
                .move_by(ahead - APPROACH_MM, MOVE_MM_S, -1.0)
                .await?;
            self.last = None;
        }
        let before = self.settle(scans).await?;
        let at_door = self.pose().await?;
        let gap = f64::from(before.sonar_mm[FORWARD]).min(APPROACH_MM + 200.0);

        // 3. Call the car and wait for the doors.
        let deadline = rome_clock::Instant::now() + wait;
        car.call(&ride.from).await.map_err(lift)?;
        self.stage(goal, "elevator: waiting for the doors").await?;
        let mut open = 0;
        while open < OPEN_SCANS {
            if rome_clock::Instant::now() >= deadline {
                return Err(NavError::Ride(format!(
                    "elevator {} did not open its doors on floor {} within {:.0} s",
                    ride.elevator, ride.from, ride.wait_s
                )));
            }
            let scan = self.next_scan(scans).await?;
            open = if f64::from(scan.sonar_mm[FORWARD]) > gap + OPEN_BEYOND_MM {
                open + 1
            } else {
                0
            };
            self.stage(goal, "elevator: waiting for the doors").await?;
        }
        car.open().await.map_err(lift)?;

        // 4. In, on infrared only.
        self.stage(goal, "elevator: entering").await?;
        self.send(Drive::Go(ENTER_MM_S)).await?;
        loop {
            let scan = self.next_scan(scans).await?;
            let pose = self.pose_of(&scan).await?;
            if IR_AHEAD.iter().any(|&i| scan.ir_lit(i)) {
                break;
            }
            if pose.dist(&at_door) > gap + CABIN_MAX_MM {
                self.send(Drive::Halt).await?;
                return Err(NavError::Ride(format!(
                    "no back wall within {:.1} m inside elevator {}",
                    CABIN_MAX_MM / 1_000.0,
                    ride.elevator
                )));
            }
        }
        self.send(Drive::Halt).await?;
        self.settle(scans).await?;
        let went = self.pose().await?.dist(&at_door);
        let inside = went - gap - ROBOT_RADIUS_MM;
        if inside < ROBOT_RADIUS_MM + INSIDE_MARGIN_MM {
            // Not clear of the doors: no turning round here. Back out, so
            // the doors can shut and the car serve others.
            self.robot.move_by(-went, ENTER_MM_S, -1.0).await?;
            self.last = None;
            self.settle(scans).await?;
            return Err(NavError::Ride(format!(
                "stopped {:.2} m past the doors of elevator {}, not inside: its infrared saw a wall too soon (bare metal walls throw infrared back; the thesis covered them)",
                inside / 1_000.0,
                ride.elevator
            )));
        }

        // 5. Turn round.
        self.stage(goal, "elevator: turning round").await?;
        self.send(Drive::Turn(180.0)).await?;
        self.settle(scans).await?;

        // 6. Ride.
        car.go(&ride.to).await.map_err(lift)?;
        car.close().await.map_err(lift)?;
        self.stage(goal, "elevator: riding").await?;
        let deadline = rome_clock::Instant::now() + wait;
        loop {
            let s = car.state().await.map_err(lift)?;
            if s.floor == ride.to && !s.moving && s.doors == Doors::Open {
                break;
            }
            if rome_clock::Instant::now() >= deadline {
                return Err(NavError::Ride(format!(
                    "elevator {} did not arrive at floor {} with its doors open within {:.0} s (it is at {}, doors {:?})",
                    ride.elevator, ride.to, ride.wait_s, s.floor, s.doors
                )));
            }
            self.stage(goal, "elevator: riding").await?;
            rome_clock::sleep(POLL).await;
        }
        car.open().await.map_err(lift)?;

        // 7. Out to the corridor's line of lights.
        self.stage(goal, "elevator: leaving").await?;
        let out = inside + ride.exit_mm as f64;
        self.robot.move_by(out, MOVE_MM_S, -1.0).await?;
        self.last = None;
        self.settle(scans).await?;
        let pose = self.pose().await?;
        self.publish(goal, &pose, false).await
    }

    /// Turns to `abeam` (degrees counter-clockwise from the present
    /// heading, which puts the door in the side camera's middle) and then
    /// about it up to ±[`SWEEP_DEG`], looking for marker `code` at each
    /// stop; once seen, turns to have it straight abeam. The marker's
    /// bearing left to turn (none after the turn) and its range, mm.
    async fn sweep(
        &mut self,
        code: Code,
        abeam: f64,
        scans: &rome_client::robot::Stream<Scan>,
    ) -> Result<Option<(f64, f64)>, NavError> {
        let steps = (SWEEP_DEG / SWEEP_STEP_DEG).round() as i32;
        let mut offsets = vec![0.0];
        offsets.extend((1..=steps).map(|k| f64::from(k) * SWEEP_STEP_DEG));
        offsets.extend((1..=steps).map(|k| -f64::from(k) * SWEEP_STEP_DEG));
        let mut facing = 0.0;
        for offset in offsets {
            let turn = abeam + offset - facing;
            if turn.abs() > 0.5 {
                self.send(Drive::Turn(turn)).await?;
            }
            facing = abeam + offset;
            let settled = self.settle(scans).await?;
            if let Some((bearing, range)) = self.look_for(code, settled.time_ms).await? {
                return Ok(Some((bearing, range)));
            }
        }
        Ok(None)
    }

    /// Marker `code` in the side camera's first image grabbed at or after
    /// device time `since_ms`: its bearing (counter-clockwise from the
    /// camera's axis) and range, mm.
    async fn look_for(&self, code: Code, since_ms: u64) -> Result<Option<(f64, f64)>, NavError> {
        let camera = "side";
        // One whole grab, so that every row is of one moment (rows are
        // served 64 to a request, and a camera grabs between them); the
        // reader scans its middle half row by row, as the thesis did with
        // CameraGetRow().
        let mut img = self.robot.camera_grab(camera).await?;
        for _ in 0..50 {
            if img.time_ms >= since_ms {
                break;
            }
            rome_clock::sleep(Duration::from_millis(100)).await;
            img = self.robot.camera_grab(camera).await?;
        }
        let rows = img.rows.len() as u32;
        let Some(gray) = image::GrayImage::from_raw(img.width, rows, img.pixels) else {
            return Ok(None);
        };
        let focal = f64::from(img.width) / 2.0 / (SIDE_FOV_DEG / 2.0).to_radians().tan();
        let found = barcode::find(&gray, rows / 4..3 * rows / 4, &ReaderConfig::default());
        Ok(found.iter().find(|f| f.code == code).map(|f| {
            let bearing = f.bearing_deg(img.width, focal);
            (bearing, f.distance_mm(focal) * bearing.to_radians().cos())
        }))
    }

    /// Takes the elevator's session, waiting while another robot rides
    /// (until `deadline`).
    async fn take_session(
        &self,
        car: &ElevatorClient,
        ride: &RideInfo,
        goal: &Goal,
        deadline: rome_clock::Instant,
    ) -> Result<rome_client::robot::Lock, NavError> {
        loop {
            self.stage(goal, "elevator: waiting for its session")
                .await?;
            match car.session().await {
                Ok(lock) => return Ok(lock),
                Err(e) if e.code() == Some(rome_schema::ErrorCode::Busy) => {
                    if rome_clock::Instant::now() >= deadline {
                        return Err(NavError::Ride(format!(
                            "elevator {} was another's for {:.0} s: {e}",
                            ride.elevator, ride.wait_s
                        )));
                    }
                    rome_clock::sleep(POLL).await;
                }
                Err(e) => return Err(NavError::Ride(format!("elevator {}: {e}", ride.elevator))),
            }
        }
    }

    /// Says where the ride is, in `Status` (and so that the Planner hears
    /// the Navigator is alive while it waits for a car).
    async fn stage(&self, goal: &Goal, state: &str) -> Result<(), NavError> {
        let pose = match self.robot.pose().await {
            Ok(p) => Pose::from(&p),
            Err(_) => Pose::default(),
        };
        let status = Status::at(self.goals, goal.goal_type, state, &pose, 0.0);
        self.board.set(Var::Status, &status).await?;
        Ok(())
    }
}

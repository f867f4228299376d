//! How the Navigator drives: its settings, the motion commands it sends,
//! and the sonar ring's geometry it steers by (Fig. 5.9, §5.4.1). Shared by
//! the Navigator's control loop and its steering states ([`crate::hallway`]).

use std::time::Duration;

/// Sonars in a ring (Fig. 5.9): 12 ahead, 18 left, 6 right, 15° apart.
pub const SONARS: usize = 24;
/// The forward sonar.
pub const FORWARD: usize = 12;
/// Degrees between sonars.
pub const SPACING: f64 = 15.0;
/// The jog rate of the superimposed turn, degrees per second (§5.4.1).
pub const JOG_RATE_DEG_S: f64 = 4.0;
/// How fast the robot steers over to keep right of an oncoming robot,
/// degrees per second.
pub const KEEP_RIGHT_JOG_DEG_S: f64 = 15.0;
/// A reading along the hallway axis at least this long means the axis is
/// open, mm.
pub const OPEN_ENOUGH_MM: u32 = 3_000;
/// The safe threshold at start, mm (§5.4.1).
pub const SAFE_START_MM: f64 = 1_000.0;
/// Something on the axis nearer than this makes the robot keep right, mm.
pub const KEEP_RIGHT_AHEAD_MM: f64 = 4_500.0;
/// The range ahead shrinking this much faster than the robot drives means
/// it comes towards the robot (1: it stands still).
pub const ONCOMING_CLOSING: f64 = 1.4;
/// Keeping off the middle, something this near within 60° of ahead (but
/// more than 15° off it) is in the way all the same, mm. A robot that
/// passes another, both keeping right, reads it farther off than this;
/// one that stands on the middle, 34–73° off ahead at the touch, the front quarter
/// would graze. Braking from cruising speed takes 267 mm at 300 mm/s²,
/// some 170 mm of it towards something 50° off ahead.
pub const PASSING_GUARD_MM: f64 = 300.0;
/// For how far after the last sighting the robot keeps right, mm.
pub const KEEP_RIGHT_FOR_MM: f64 = 3_000.0;
/// How far right of the axis a robot bears with no walls to steer by, degrees.
pub const KEEP_RIGHT_BEAR_DEG: f64 = 8.0;
/// A robot's radius, mm (a Pioneer-sized disc): sonar ranges start this
/// far out from its middle.
pub const ROBOT_RADIUS_MM: f64 = 380.0;
/// Room between two bodies when one passes the other standing aside, mm.
pub const PASS_ROOM_MM: f64 = 150.0;
/// A robot's radius with room to spare when keeping right, mm.
pub const ROBOT_CLEARANCE_MM: f64 = ROBOT_RADIUS_MM + 300.0;
/// A side sonar (5–7 right, 17–19 left) reading less than this has a wall
/// or a robot nearer the skin than the ring can follow, mm: 50 mm past its
/// shortest range ([`rome_schema::robot::body::SONAR_MIN_MM`]), below
/// which everything reads alike, so the side walls no longer say how the
/// robot moves along them.
pub const SIDE_TOUCH_MM: u32 = 200;
/// The other side's sonars must all read at least this for the robot to
/// bear away from a near side, mm: more than a robot passing beside
/// reads, less than the far wall of the narrowest corridor (2 m) reads
/// from a robot 150 mm off the near one.
pub const SIDE_TOUCH_ROOM_MM: u32 = 1_000;
/// In the Corner state, the side a robot bears away to from a near side
/// must read at least this, mm: twice [`SIDE_TOUCH_MM`], so that bearing
/// away does not make the other side the near one.
pub const CORNER_SIDE_ROOM_MM: u32 = 2 * SIDE_TOUCH_MM;
/// How fast the robot bears away from a side that near, degrees per
/// second: at cruising speed a heading 10° into the wall is undone within
/// half a metre, before the 150 mm to the wall are driven.
pub const SIDE_TOUCH_JOG_DEG_S: f64 = 8.0;

/// How the Navigator drives.
#[derive(Debug, Clone, PartialEq)]
pub struct NavConfig {
    /// Cruising speed, mm/s.
    pub cruise_mm_s: f64,
    /// Speed leaving a corner, mm/s.
    pub corner_mm_s: f64,
    /// Period of Check-Bumper and Check-Goal, ms of robot time (3–5 s).
    pub check_period_ms: u64,
    /// In-place turns within [`NavConfig::busy_window_ms`] that count as
    /// "too many": the safe threshold is halved.
    pub busy_turns: usize,
    /// Window for counting turns, ms.
    pub busy_window_ms: u64,
    /// Calm time after which the threshold grows by 25 %, ms.
    pub calm_ms: u64,
    /// Smallest safe threshold, mm.
    pub safe_min_mm: f64,
    /// Deceleration the base uses to stop, mm/s² (to stop on the goal).
    pub stop_accel_mm_s2: f64,
    /// Longest wait for a scan before the proximity server counts as gone.
    pub scan_timeout: Duration,
    /// Scans without a new goal after which a moving robot is stopped
    /// (2 s of robot time at the sonar ring's 10 scans a second).
    pub idle_scans: usize,
    /// How long a read of the light count may go unanswered before the
    /// robot is stopped: without it an L goal cannot tell when it ends.
    pub blind_after: Duration,
    /// Whether the base stops itself on a touch (Set Bumper) and
    /// Check-Bumper looks as soon as a robot told to drive stands still.
    /// Else, as the thesis' Navigator, a robot pushes on until
    /// Check-Bumper's next periodic look, its wheels turning while its
    /// body stands and its odometry counting what it never drove.
    pub stop_on_contact: bool,
    /// Whether a robot that ends a D goal more than 0.3 m across from the
    /// goal's line (steering round people, say) steps sideways onto it.
    pub onto_line: bool,
    /// Whether a robot making way for something coming towards it steers
    /// over briskly ([`KEEP_RIGHT_JOG_DEG_S`]), so that two robots are
    /// across before they meet in a 2.44 m corridor. Else at the
    /// hallway's gentle rate, as the thesis' Navigator steered.
    pub brisk_keep_right: bool,
    /// Whether, keeping off the middle, something nearer than
    /// [`PASSING_GUARD_MM`] 20–60° off ahead turns the robot away. Else,
    /// as before, only what is within 15° of ahead does, and a robot
    /// keeping right grazes one that stands on the middle.
    pub front_quarter_guard: bool,
    /// Whether Center-Hallway bears away from a side nearer than
    /// [`SIDE_TOUCH_MM`] while the other side is clear
    /// (`hallway::side_touch`). Else, as before, a robot within the side
    /// sonars' shortest range of a wall drives on by odometry's heading.
    pub bear_off_near_side: bool,
    /// Whether an Enter-Corner goal keeps right for an oncoming robot,
    /// driven by Center-Hallway while it does (docs/navigation.md). Else
    /// the whole goal is the Corner state's, as the thesis has it.
    pub corner_keep_right: bool,
    /// Whether a Leave-Corner goal does the same. Off by default: it ends
    /// the runaway of a robot that spun away from one met as it left a
    /// corner, and helps ten robots, but forty touched each other more
    /// (docs/traffic.md, "Keeping right out of a corner").
    pub leave_corner_keep_right: bool,
    /// Whether something standing ahead off the corridor's middle (a
    /// robot stood aside) is passed on its far side with
    /// [`PASS_ROOM_MM`] between the two bodies
    /// (`hallway::Passing`). Else, as before, the robot steers back to the
    /// middle and passes as near as its safe threshold lets it.
    pub pass_wide: bool,
    /// Whether a robot blocked (no headway for
    /// [`crate::navigator::blocked::BLOCKED_AFTER_MS`]) stands while its way stays
    /// closed, instead of making Center-Hallway's safety turn. Else, as
    /// before, it turns to and fro before what closes the way, taking up
    /// after each turn the Go it turned out of.
    pub stand_when_blocked: bool,
    /// Whether a safety turn with something in front nearer than the
    /// robot brakes in from the speed it drives at ([`stops_short`],
    /// [`Speedometer`]) stops the base at once before it turns. Else, as
    /// before, the turn brakes at the acceleration setting while the
    /// robot turns, and drives on into what it turned from: a robot
    /// standing in a junction was touched so. Off by default, on in
    /// `rome fleet`: a robot alone among people touched them less with it,
    /// but ended one run in forty 1.04 m from its goal (docs/traffic.md,
    /// "Braking before a safety turn").
    pub stop_short_to_turn: bool,
    /// Whether the Corner state, its detectors clear, bears away from a
    /// side nearer than [`SIDE_TOUCH_MM`] while the other side has
    /// [`CORNER_SIDE_ROOM_MM`] (`hallway::corner_side_touch`). Else, as
    /// before, it steers by the walls and the goal direction, towards
    /// what stands beside it as readily as away. Off by default, on in
    /// `rome fleet`: a robot alone among people touched them less with
    /// it, but judged one corner in forty failed (docs/traffic.md,
    /// "Setting off beside a robot").
    pub corner_bears_off: bool,
    /// Whether Center-Hallway drives no faster than lets it stop halfway
    /// to the nearest echo within 15° of ahead ([`ahead_speed_cap`]), so
    /// that two robots closing head on both stop short of each other.
    /// Else, as before, the robot cruises until the safe threshold turns
    /// it, which after many turns is 0.35 m: less than a robot at cruise
    /// brakes in when the other comes too. Off by default, and in
    /// `rome fleet` unless `--brake-ahead`: fewer touches among robots
    /// given a backlog, but one task of 500 lost on the Campus
    /// (docs/traffic.md, "Driving no faster than it can stop").
    pub brake_for_ahead: bool,
    /// Whether Center-Hallway, swerving briskly (keeping right for
    /// something coming, or passing) with no new sample of both walls (a
    /// side opened, or a recess), steers by where the walls last were,
    /// carried on by the odometry's turn and travel since, for up to 3 m.
    /// Else, as before, by the last samples as they are, for up to a
    /// metre: the correction they give does not change as the robot turns,
    /// and keeping right into a junction a robot swung 45° off the axis
    /// (docs/traffic.md, "Walls carried on by odometry"). Off by default,
    /// on in `rome fleet`.
    pub coast_on_odometry: bool,
    /// Whether an Enter-Corner, Leave-Corner or Dead-Reckoning goal hears
    /// the glass the map has near it (`Glass`, written by the Planner),
    /// placed by odometry, as its sensors would hear a wall
    /// (`navigator::glass`). Else, as the thesis' Navigator, it goes by
    /// what the sensors hear, and glass is not heard. Off by default, on
    /// in `rome fleet`: `rome experiment` keeps the thesis' runs, the one
    /// into the glass door included (docs/traffic.md, "The glass the
    /// sonars do not hear").
    pub hear_glass: bool,
    /// Whether a near echo ahead that its sonar loses is kept for a metre
    /// driven, placed by odometry, and fills in the sonars within 45° of
    /// ahead that no longer hear it (`navigator::echoes`): the convex
    /// corner of a corridor's mouth, heard ahead, slides into the gap
    /// between two beams as the robot closes on it at a slant. Else, as
    /// the thesis' Navigator, each scan is read alone. Off by default and
    /// in `rome fleet` (`--remember-echoes`): among forty robots on the
    /// Campus it took two corner touches of three away, but robots in
    /// EB3's backlogs block each other more (docs/traffic.md, "The
    /// corner between two beams").
    pub remember_echoes: bool,
    /// Whether, outside the Corner state, a forward infrared detector
    /// (15° right or left of ahead) that sees something none of the three
    /// sonars ahead hears as near turns the robot away from it
    /// (`navigator::infrared`): the corner between two beams, within the
    /// detectors' reach. Else, as the thesis' Center-Hallway state, the
    /// sonars alone steer. Off by default and in `rome fleet`
    /// (`--infrared-ahead`): in EB3's backlogs it took every contact away;
    /// on the Campus, over eight runs, walls were touched half as often
    /// and robots a little more often, and in the run tasks.md shows, a
    /// hundred robots touched each other ten times against two
    /// (docs/traffic.md, "The forward infrared outside the Corner state").
    pub infrared_ahead: bool,
    /// Whether the Center-Hallway state carries where the walls were on
    /// by odometry at every scan, and, where a side has opened (a
    /// junction, a door's recess), turns back towards the middle before
    /// the robot's side would cross the line of a wall half a metre on.
    /// Off by default: it moved contacts rather than ended them
    /// (docs/traffic.md, "Back within the walls after a crossroads").
    pub keep_within_walls: bool,
    /// With `keep_within_walls`: once the walls carried on are let go (a
    /// turn of more than 45°, or 3 m driven), take up where the robot is
    /// from the one wall in view, by the last fit's axis and width, for
    /// up to 6 m. Off by default: fewer contacts on the Campus, more in
    /// EB3's backlogs (docs/traffic.md, "Where the walls were, from one
    /// wall").
    pub walls_from_one_side: bool,
    /// Whether the Corner state, turned to within 20° of the goal
    /// direction with only a 45° detector lit and no echo in the strip it
    /// would sweep over the next metre, goes on bearing away from what
    /// the detector sees (`hallway::corner_step`). Else, as the thesis,
    /// it spins away from it, and on past the goal direction: a robot
    /// turned into a corridor with its wall a quarter of a metre off its
    /// side, and another robot behind it, spun in place for minutes and
    /// held three robots up (docs/traffic.md, "Spinning in a corridor's
    /// mouth"). Off by default and in `rome fleet` (`--corner-creeps`).
    pub corner_creeps: bool,
}

impl Default for NavConfig {
    fn default() -> Self {
        NavConfig {
            cruise_mm_s: 400.0,
            corner_mm_s: 250.0,
            check_period_ms: 4_000,
            busy_turns: 3,
            busy_window_ms: 15_000,
            calm_ms: 20_000,
            safe_min_mm: 350.0,
            // The base's own acceleration setting (Table 4.1), which it
            // also brakes at: the simulator's 300 mm/s².
            stop_accel_mm_s2: 300.0,
            scan_timeout: Duration::from_secs(10),
            idle_scans: 20,
            blind_after: Duration::from_secs(1),
            stop_on_contact: true,
            onto_line: true,
            brisk_keep_right: true,
            front_quarter_guard: true,
            bear_off_near_side: true,
            corner_keep_right: true,
            leave_corner_keep_right: false,
            pass_wide: true,
            stand_when_blocked: true,
            stop_short_to_turn: false,
            corner_bears_off: false,
            brake_for_ahead: false,
            coast_on_odometry: false,
            hear_glass: false,
            remember_echoes: false,
            infrared_ahead: false,
            keep_within_walls: false,
            walls_from_one_side: false,
            corner_creeps: false,
        }
    }
}

/// Room left before the nearest echo ahead when braked to a stand by
/// [`ahead_speed_cap`], mm: above the sonars' shortest reading.
pub const BRAKE_ROOM_MM: f64 = 200.0;

/// The fastest a robot may drive with the nearest echo within 15° of
/// ahead (sonars 11–13) where it is, braking at `accel_mm_s2` and acting
/// `late_s` after the echo was read: what it covers in that time and in
/// braking, twice over (the echo may be a robot coming as fast and
/// braking as late), fits in the room beyond [`BRAKE_ROOM_MM`]. That is
/// v² / a + 2 v t ≤ room, solved for v.
pub fn ahead_speed_cap(sonar: &[u32], accel_mm_s2: f64, late_s: f64) -> f64 {
    let ahead = sonar
        .get(11..=13)
        .and_then(|s| s.iter().min())
        .map_or(f64::INFINITY, |&r| f64::from(r));
    if ahead >= rome_schema::robot::body::SONAR_MAX_MM {
        return f64::INFINITY;
    }
    let a = accel_mm_s2.max(1.0);
    let at = a * late_s.max(0.0);
    let room = (ahead - BRAKE_ROOM_MM).max(0.0);
    (at * at + a * room).sqrt() - at
}

/// How far the speed set may lie from what the throttle wants before a Go
/// sets it again, mm/s: a cap that eases scan by scan is not sent each
/// time.
pub const THROTTLE_STEP_MM_S: f64 = 25.0;

/// The speed the base was set to with Go, what the Navigator's states
/// asked for, and what caps it ([`NavConfig::brake_for_ahead`]). A jog
/// moves at the speed setting, so a cap applies while steering too.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Throttle {
    /// The last speed set with Go, mm/s.
    pub set: f64,
    /// The last speed a state asked for with Go, mm/s.
    pub wanted: f64,
    /// The cap at the scan at hand, mm/s (infinite: none).
    pub cap: f64,
}

impl Throttle {
    /// Set to `mm_s`, with no cap.
    pub fn new(mm_s: f64) -> Throttle {
        Throttle {
            set: mm_s,
            wanted: mm_s,
            cap: f64::INFINITY,
        }
    }

    /// What a Go or a jog should move at now, mm/s.
    pub fn target(&self) -> f64 {
        self.wanted.min(self.cap)
    }

    /// Whether the speed set is far enough from the target to set again.
    pub fn stale(&self) -> bool {
        (self.target() - self.set).abs() > THROTTLE_STEP_MM_S
    }
}

/// The sonars Center-Hallway's safety rule watches: those within 60° of
/// ahead (§5.4.1).
pub const SAFETY_SONARS: std::ops::RangeInclusive<usize> = 8..=16;
/// Room kept beyond the braking distance before a safety turn, mm.
pub const TURN_ROOM_MM: f64 = 100.0;

/// How long after a scan what the robot decides from it takes effect, s:
/// a scan period, and a round trip of `rtt_s` (at most a second).
pub fn reaction_s(rtt_s: f64) -> f64 {
    0.1 + rtt_s.clamp(0.0, 1.0)
}

/// Whether something within 60° of ahead ([`SAFETY_SONARS`]) is nearer
/// than a robot driving at `speed_mm_s` covers while it brakes at
/// `accel_mm_s2`, after a scan period and a round trip of `rtt_s`, with
/// [`TURN_ROOM_MM`] to spare. A point turn brakes as it turns: from
/// cruising speed it carries the robot 267 mm on.
pub fn stops_short(sonar: &[u32], speed_mm_s: f64, accel_mm_s2: f64, rtt_s: f64) -> bool {
    let v = speed_mm_s.abs();
    let braking = v * v / (2.0 * accel_mm_s2.max(1.0));
    let late = v * reaction_s(rtt_s);
    let need = braking + late + TURN_ROOM_MM;
    sonar
        .get(SAFETY_SONARS)
        .is_some_and(|front| front.iter().any(|&r| f64::from(r) < need))
}

/// The robot's speed along its track, from odometry at each scan: what a
/// stop brakes from, whatever speed was last set (a robot that just
/// turned in place and drives off again is still slow).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Speedometer {
    at: Option<(u64, f64)>,
    mm_s: f64,
}

impl Speedometer {
    /// Takes the distance driven by `t_ms`, mm; the speed, smoothed over a
    /// few scans, mm/s.
    pub fn update(&mut self, t_ms: u64, odometer_mm: f64) -> f64 {
        match self.at {
            Some((t0, d0)) if t_ms > t0 => {
                let v = (odometer_mm - d0) / ((t_ms - t0) as f64 / 1_000.0);
                self.mm_s = 0.5 * self.mm_s + 0.5 * v;
            }
            Some((t0, _)) if t_ms == t0 => return self.mm_s,
            _ => {}
        }
        self.at = Some((t_ms, odometer_mm));
        self.mm_s
    }

    /// The last speed taken, mm/s.
    pub fn mm_s(&self) -> f64 {
        self.mm_s
    }
}

/// A motion command, sent only when it differs from the last one.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Drive {
    /// Straight on, holding the heading, mm/s.
    Go(f64),
    /// Superimposed turn, degrees per second counter-clockwise (the base's
    /// jog is clockwise-positive; the sign is flipped when sent).
    Jog(f64),
    /// Stop and turn in place by degrees counter-clockwise, then go on.
    Turn(f64),
    /// Stand and turn slowly, degrees per second counter-clockwise (the
    /// Corner state's stop-and-go).
    Spin(f64),
    /// Stand still.
    Halt,
}

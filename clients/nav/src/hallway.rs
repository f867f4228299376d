//! What the Navigator's Center-Hallway and Corner states steer by: the
//! sonar ring's geometry, the hallway model (safe threshold, keeping right
//! of oncoming robots) and the walls fitted to the side sonars (§5.4;
//! [`walls`]).

use crate::bodies::bodies;
use crate::drive::{
    Drive, NavConfig, CORNER_SIDE_ROOM_MM, FORWARD, JOG_RATE_DEG_S, KEEP_RIGHT_AHEAD_MM,
    KEEP_RIGHT_BEAR_DEG, KEEP_RIGHT_FOR_MM, KEEP_RIGHT_JOG_DEG_S, ONCOMING_CLOSING, OPEN_ENOUGH_MM,
    PASSING_GUARD_MM, PASS_ROOM_MM, ROBOT_CLEARANCE_MM, ROBOT_RADIUS_MM, SAFETY_SONARS,
    SAFE_START_MM, SIDE_TOUCH_JOG_DEG_S, SIDE_TOUCH_MM, SIDE_TOUCH_ROOM_MM, SONARS, SPACING,
};
use rome_maps::geometry::normalize_deg;
use rome_schema::robot::Scan;

#[cfg(test)]
mod tests;
pub mod walls;
pub use walls::Walls;

/// The sonar index `k` steps from `i`, modulo 24.
pub fn sonar_add(i: usize, k: i64) -> usize {
    (i as i64 + k).rem_euclid(SONARS as i64) as usize
}

/// The bearing of sonar `i` from the heading, degrees counter-clockwise.
pub fn bearing(i: usize) -> f64 {
    normalize_deg((i as f64 - FORWARD as f64) * SPACING)
}

/// The sonar pointing closest to a bearing (degrees counter-clockwise from
/// the heading): M of §5.4.1.
pub fn sonar_towards(bearing_deg: f64) -> usize {
    sonar_add(
        FORWARD,
        (normalize_deg(bearing_deg) / SPACING).round() as i64,
    )
}

/// The open direction (§5.4.1): the largest reading among sonars
/// M−2 … M+2 (modulo 24) around the hallway axis estimated from the heading
/// and the goal direction; of equal readings the one nearest M. `half`
/// narrows the window (the Corner state uses 1).
pub fn open_sonar(sonar: &[u32], heading_deg: f64, axis_deg: f64, half: i64) -> usize {
    let m = sonar_towards(axis_deg - heading_deg);
    if sonar[m] >= OPEN_ENOUGH_MM {
        // The axis itself is open: a longer reading beside it is a side
        // corridor or a door ahead, not the way to go.
        return m;
    }
    let mut best = m;
    for k in (-half..=half).filter(|k| *k != 0) {
        let i = sonar_add(m, k);
        let better = f64::from(sonar[i]) > f64::from(sonar[best]) * 1.05;
        let tie = !better && f64::from(sonar[i]) * 1.05 >= f64::from(sonar[best]);
        let nearer = (k.unsigned_abs() as usize) < circular(best, m);
        if better || (tie && nearer && sonar[i] > sonar[best]) {
            best = i;
        }
    }
    best
}

/// Beyond the thesis: which way to bear (+1 counter-clockwise, −1
/// clockwise) when one side's sonars read a wall or a robot nearer the
/// skin than [`SIDE_TOUCH_MM`] and the other side is clear for
/// [`SIDE_TOUCH_ROOM_MM`]. So near, the side sonar reads its shortest
/// range whatever the distance, and a heading a few degrees into the wall
/// (odometry's heading error, on a robot setting out from beside a wall)
/// goes unseen until the touch. Something on the other side too (a
/// doorway, or a robot passing) leaves no side to bear to.
pub fn side_touch(sonar: &[u32]) -> Option<f64> {
    bear_off(sonar, SIDE_TOUCH_ROOM_MM)
}

/// The Corner state's [`side_touch`]: in a corner the other side is a
/// wall a robot's width off, not a corridor's, so it need only have room
/// to bear into ([`CORNER_SIDE_ROOM_MM`]).
pub fn corner_side_touch(sonar: &[u32]) -> Option<f64> {
    bear_off(sonar, CORNER_SIDE_ROOM_MM)
}

/// Away from a side whose sonars read under [`SIDE_TOUCH_MM`] when every
/// sonar on the other side reads at least `room_mm`.
fn bear_off(sonar: &[u32], room_mm: u32) -> Option<f64> {
    let near = |side: [usize; 3]| side.iter().any(|&i| sonar[i] < SIDE_TOUCH_MM);
    let clear = |side: [usize; 3]| side.iter().all(|&i| sonar[i] >= room_mm);
    let (right, left) = ([5, 6, 7], [17, 18, 19]);
    if near(right) && clear(left) {
        Some(1.0)
    } else if near(left) && clear(right) {
        Some(-1.0)
    } else {
        None
    }
}

fn circular(a: usize, b: usize) -> usize {
    let d = a.abs_diff(b);
    d.min(SONARS - d)
}

/// The Center-Hallway state's memory: its safe threshold and when it last
/// turned (§5.4.1).
#[derive(Debug, Clone, PartialEq)]
pub struct Hallway {
    /// The safe threshold, mm.
    pub safe_mm: f64,
    /// How far the goal still is along the hallway, mm (infinite when the
    /// goal is a count of lights): something ahead nearer than that is in
    /// the way, not the hallway's end.
    pub room_mm: f64,
    pub(crate) walls: Walls,
    turns: Vec<u64>,
    calm_since: u64,
    slow_until: u64,
    /// Whether another robot comes head-on, and how long to keep right.
    pub oncoming: Oncoming,
    /// Something standing ahead off the middle, being passed wide.
    pub passing: Passing,
    /// Since when the robot has waited before something standing that
    /// leaves no lane, ms; kept until the way opens, so it waits once.
    hold_since: Option<u64>,
    /// Where across the hallway to keep, mm left of its middle: a goal
    /// that lies off the middle (a door on a corridor's end wall) is
    /// approached along its own line, as far as the walls leave room.
    pub lane_mm: f64,
}

impl Hallway {
    /// A fresh state at time `now_ms`, threshold 1 m.
    pub fn new(now_ms: u64) -> Hallway {
        Hallway {
            safe_mm: SAFE_START_MM,
            room_mm: f64::INFINITY,
            walls: Walls::default(),
            turns: Vec::new(),
            calm_since: now_ms,
            slow_until: 0,
            oncoming: Oncoming::default(),
            passing: Passing::default(),
            hold_since: None,
            lane_mm: 0.0,
        }
    }

    /// One pass of Center-Hallway: what to do given the sonar ranges, the
    /// odometry heading, the goal direction and the distance driven so far.
    pub fn step(
        &mut self,
        cfg: &NavConfig,
        sonar: &[u32],
        heading_deg: f64,
        goal_deg: f64,
        along_mm: f64,
        now_ms: u64,
    ) -> Drive {
        self.adapt(cfg, now_ms);
        self.walls.guarding = cfg.keep_within_walls;
        if cfg.keep_within_walls {
            // Every scan, whichever rule steers it: the turns of the open
            // direction and of the safety rule move the robot across too.
            self.walls.carry(along_mm, heading_deg);
            if cfg.walls_from_one_side {
                self.walls.reanchor(sonar, along_mm, heading_deg);
            }
        }
        let speed = if now_ms < self.slow_until {
            cfg.cruise_mm_s * 0.75
        } else {
            cfg.cruise_mm_s
        };
        let keep_right = self.oncoming.watch(sonar, along_mm, self.room_mm);
        let pass = if cfg.pass_wide && !keep_right {
            let rel = normalize_deg(heading_deg - goal_deg);
            self.passing
                .watch(sonar, &self.walls, rel, along_mm, self.room_mm)
        } else {
            None
        };
        // Beyond the thesis: something standing ahead that no lane passes
        // (a robot that has stopped on the middle at its goal) is waited
        // for, stood still short of it, before the safe threshold's turns
        // swing the robot into the gap beside it, towards the wall and
        // towards where a robot at its goal steps aside to. Among a
        // hundred robots such turns, braked with the other body a
        // fifth of a metre off the side, ended in a touch
        // (docs/traffic.md, "Waiting for one that stands in the way").
        let no_way = self
            .passing
            .no_way()
            .filter(|_| cfg.pass_wide && !keep_right);
        match no_way {
            Some(r) if r < HOLD_WITHIN_MM => {
                let since = *self.hold_since.get_or_insert(now_ms);
                if now_ms.saturating_sub(since) < HOLD_MS {
                    return Drive::Halt;
                }
            }
            Some(_) => {}
            None => self.hold_since = None,
        }
        // Keeping off the middle, for another robot or for the goal, the
        // near wall lies within 60° of ahead: only what is ahead counts.
        let off_middle = keep_right || pass.is_some() || self.lane_mm != 0.0;
        // Safety: a reading below the threshold within 60° of ahead. The
        // thesis excepts sonars 6 and 18; their neighbours 5, 7, 17 and 19
        // see the same side walls at nearly the same range, so they are
        // excepted too. Keeping right to pass, a robot passing abeam is
        // expected: then only 15° either side of ahead counts at the safe
        // threshold. Beyond the thesis: the rest of the 60° still counts
        // at a short guard, because the robot that stands on the middle
        // (34–73° off ahead at the touch) is the one a robot keeping right grazes with its
        // front quarter.
        let limit = |i: usize| {
            if off_middle && !(11..=13).contains(&i) {
                if cfg.front_quarter_guard {
                    PASSING_GUARD_MM.min(self.safe_mm)
                } else {
                    0.0
                }
            } else {
                self.safe_mm
            }
        };
        let closed = SAFETY_SONARS
            .map(|i| (i, sonar[i]))
            .filter(|(i, r)| f64::from(*r) < limit(*i))
            .min_by_key(|(_, r)| *r);
        if let Some((closest, _)) = closed {
            // Turn so the closed direction lies on sonar 6 or 18, whichever
            // leaves the heading nearer the goal direction.
            let closed = heading_deg + bearing(closest);
            let left = normalize_deg(closed - 90.0 - heading_deg);
            let right = normalize_deg(closed + 90.0 - heading_deg);
            let err = |d: f64| normalize_deg(heading_deg + d - goal_deg).abs();
            let turn = if err(left) <= err(right) { left } else { right };
            let turn = turn.clamp(-30.0, 30.0);
            if turn.abs() >= 5.0 {
                self.turns.push(now_ms);
                self.calm_since = now_ms;
                self.slow_until = now_ms + cfg.calm_ms;
                return Drive::Turn(turn);
            }
        }
        if let Some(turn) = self
            .walls
            .back_within(sonar)
            .filter(|_| cfg.keep_within_walls)
        {
            tracing::debug!(turn, "hallway: turning back within the walls");
            return Drive::Turn(turn);
        }
        if let Some(away) = side_touch(sonar).filter(|_| cfg.bear_off_near_side) {
            return Drive::Jog(away * SIDE_TOUCH_JOG_DEG_S);
        }
        let room = self.walls.keep_right_mm();
        let brisk = (keep_right || pass.is_some()) && cfg.brisk_keep_right;
        self.walls.brisk = brisk;
        self.walls.coasting = cfg.coast_on_odometry;
        self.walls.lane_mm = match pass {
            _ if keep_right => -room,
            Some(lane) => lane,
            None => self.lane_mm.clamp(-room, room),
        };
        // Safe: steer the open direction onto sonar 12.
        let open = open_sonar(sonar, heading_deg, goal_deg, 2);
        let delta = if open != sonar_towards(goal_deg - heading_deg) && !off_middle {
            bearing(open)
        } else if let Some(d) = self.walls.steer(
            sonar,
            // Swerving to keep right, the robot turns up to 30° from the
            // axis, where sonars 6 and 18 hear no echo: the walls are read
            // square on. Elsewhere as the thesis' Navigator read them.
            if brisk {
                normalize_deg(heading_deg - goal_deg)
            } else {
                0.0
            },
            along_mm,
            heading_deg,
        ) {
            // The open direction is the axis itself, which odometry alone
            // cannot hold to a degree: the side walls say how the robot
            // moves relative to them and how far off the middle it is.
            d
        } else if keep_right {
            // No walls to steer by: bear a little right of the axis.
            normalize_deg(goal_deg - KEEP_RIGHT_BEAR_DEG - heading_deg)
        } else {
            normalize_deg(goal_deg - heading_deg)
        };
        if delta.abs() < 1.0 {
            Drive::Go(speed)
        } else if brisk {
            // Out of the way of an oncoming robot before the two meet: at
            // 4°/s the robot would still be turning when they pass.
            Drive::Jog(delta.signum() * KEEP_RIGHT_JOG_DEG_S)
        } else {
            Drive::Jog(delta.signum() * JOG_RATE_DEG_S)
        }
    }

    fn adapt(&mut self, cfg: &NavConfig, now_ms: u64) {
        self.turns
            .retain(|t| now_ms.saturating_sub(*t) <= cfg.busy_window_ms);
        if self.turns.len() >= cfg.busy_turns {
            self.safe_mm = (self.safe_mm * 0.5).max(cfg.safe_min_mm);
            self.turns.clear();
        } else if now_ms.saturating_sub(self.calm_since) >= cfg.calm_ms {
            self.safe_mm = (self.safe_mm * 1.25).min(SAFE_START_MM);
            self.calm_since = now_ms;
        }
    }
}

/// Beyond the thesis: something on the axis ahead that comes towards the
/// robot (the range shrinks faster than the robot drives: another robot,
/// met head-on) makes it keep to the right for the next few metres, so the
/// two pass each other as people do in a hallway. Something still or going
/// the same way is left to the open direction, as any obstacle.
#[derive(Debug, Clone, PartialEq)]
pub struct Oncoming {
    /// (distance driven, range on the axis ahead) over the last metre and
    /// a half, while something is there, mm.
    ahead: std::collections::VecDeque<(f64, f64)>,
    /// Keep to the right until the robot has driven this far, mm.
    until: f64,
}

impl Default for Oncoming {
    fn default() -> Oncoming {
        Oncoming {
            ahead: std::collections::VecDeque::new(),
            until: f64::NEG_INFINITY,
        }
    }
}

impl Oncoming {
    /// Adds a scan taken `along_mm` into the drive, with the goal
    /// `room_mm` ahead (nearer than that, something is in the way, not the
    /// hallway's end); whether to keep right now. A scan seen twice at the
    /// same distance counts once.
    pub fn watch(&mut self, sonar: &[u32], along_mm: f64, room_mm: f64) -> bool {
        let ahead = (11..=13)
            .map(|i| f64::from(sonar[i]))
            .fold(f64::MAX, f64::min);
        if ahead > 600.0 && ahead < KEEP_RIGHT_AHEAD_MM && ahead + 500.0 < room_mm {
            self.ahead
                .retain(|(a, _)| along_mm - a <= 1_500.0 && *a <= along_mm);
            if self.ahead.back() != Some(&(along_mm, ahead)) {
                self.ahead.push_back((along_mm, ahead));
            }
            if let (Some(first), Some(last)) = (self.ahead.front(), self.ahead.back()) {
                let driven = last.0 - first.0;
                if driven >= 300.0 && (first.1 - last.1) / driven > ONCOMING_CLOSING {
                    // What set it off, for a trace: a corridor's mouth
                    // ahead can (docs/traffic.md, "A corridor's mouth
                    // taken for a robot coming").
                    if along_mm >= self.until {
                        tracing::debug!(
                            from = first.1,
                            to = last.1,
                            driven,
                            "oncoming: something ahead comes towards the robot; keeping right"
                        );
                    }
                    self.until = along_mm + KEEP_RIGHT_FOR_MM;
                }
            }
        } else {
            self.ahead.clear();
        }
        along_mm < self.until
    }
}

/// Beyond the thesis: something that stands ahead off the middle of a
/// corridor whose walls are known (a robot stood aside to let others by)
/// is passed on the side with more room, [`PASS_ROOM_MM`] clear of it.
/// Steering back to the middle, the thesis' robot passes it as near as the
/// safe threshold lets it: among forty robots in a 2.2 m corridor, 0.6 m
/// between the two middles, where under 0.76 m they touch. Each echo
/// ahead is taken for the near side of a robot-sized disc, neighbouring
/// echoes that one disc explains for that one ([`crate::bodies`]); once the
/// nearest such disc has drawn nearer no faster than the robot drives,
/// over 0.3 m driven (it stands still: one that comes towards the robot
/// is met by keeping right, [`Oncoming`]), the lane is kept until the
/// robot has driven past the farthest.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Passing {
    /// (lane, mm left of the middle; keep it until this far driven, mm).
    lane: Option<(f64, f64)>,
    /// (distance driven, how far ahead the nearest such disc stood) over
    /// the last metre and a half while one is seen, mm: one that comes
    /// towards the robot is met by keeping right, not passed.
    seen: std::collections::VecDeque<(f64, f64)>,
    /// From the last scan: how near something standing still is, mm from
    /// the skin, when no lane between the walls passes it.
    no_way: Option<f64>,
}

/// How far ahead something standing is passed wide, mm.
const PASS_AHEAD_MM: f64 = 3_000.0;

/// How near something standing that leaves no lane is waited for, mm
/// from the skin: braking from cruising speed stops the robot well short
/// of it, and of the safe threshold's turns.
const HOLD_WITHIN_MM: f64 = 1_000.0;

/// How long something standing that leaves no lane is waited for, ms of
/// robot time: a robot at its goal steps aside within a few seconds; one
/// that stays is passed as before, well before the Navigator calls itself
/// blocked.
const HOLD_MS: u64 = 10_000;

/// Something drawing nearer slower than this many times what the robot
/// drives moves away ahead of it: it is not waited for.
const STAND_CLOSING: f64 = 0.8;

/// Something drawing nearer than this many times what the robot drives
/// does not stand still (1: it does; a sonar's few centimetres of noise
/// over the 0.3 m judged stay well under it).
const STILL_CLOSING: f64 = 1.2;

impl Passing {
    /// Adds a scan taken `along_mm` into the drive, heading `rel_deg`
    /// counter-clockwise of the corridor's axis, the goal `room_mm` ahead:
    /// the lane to keep, mm left of the middle, if something is to be
    /// passed wide and the walls leave room for it.
    pub fn watch(
        &mut self,
        sonar: &[u32],
        walls: &Walls,
        rel_deg: f64,
        along_mm: f64,
        room_mm: f64,
    ) -> Option<f64> {
        self.no_way = None;
        let (Some(width), Some(&(_, offset, _, _))) = (walls.width(), walls.samples.back()) else {
            self.lane = None;
            return None;
        };
        // From the middle to either wall, mm.
        let half = width / 2.0 + ROBOT_RADIUS_MM;
        // Where the robot's middle may go: as far over as it keeps right.
        let reach = half - ROBOT_CLEARANCE_MM;
        let (mut lo, mut hi, mut past, mut nearest) = (-reach, reach, None::<f64>, f64::MAX);
        // The nearest echo of each body that stands in the way, mm.
        let mut echo_mm = f64::MAX;
        for body in bodies(sonar, 9, 15, PASS_AHEAD_MM) {
            let (i, r) = body.nearest;
            let b = (body.bearing_deg + rel_deg).to_radians();
            // The disc's middle: where one disc explains neighbouring
            // echoes, else one radius behind the echo along the beam.
            let d = body.distance_mm;
            let (ahead, across) = (d * b.cos(), offset + d * b.sin());
            let echo_across =
                offset + (ROBOT_RADIUS_MM + r) * (bearing(i) + rel_deg).to_radians().sin();
            if ahead <= 0.0 || ahead > PASS_AHEAD_MM || ahead + 500.0 > room_mm {
                continue;
            }
            // A wall, a door's jamb or a corner: not something standing
            // (nor is a disc whose middle would lie nearer a wall than a
            // robot's middle can).
            if echo_across.abs() > half - 150.0 || across.abs() > half - ROBOT_RADIUS_MM + 100.0 {
                continue;
            }
            let clear = 2.0 * ROBOT_RADIUS_MM + PASS_ROOM_MM;
            if across >= 0.0 {
                hi = hi.min(across - clear);
            } else {
                lo = lo.max(across + clear);
            }
            tracing::debug!(
                sonar = i,
                r,
                ahead,
                across,
                half,
                offset,
                "passing: something standing"
            );
            past = Some(past.map_or(ahead, |p: f64| p.max(ahead)));
            nearest = nearest.min(ahead);
            echo_mm = echo_mm.min(r);
        }
        if past.is_none() {
            self.seen.clear();
        } else {
            self.seen
                .retain(|(a, _)| along_mm - a <= 1_500.0 && *a <= along_mm);
            self.seen.push_back((along_mm, nearest));
        }
        let still = match (self.seen.front(), self.seen.back()) {
            (Some(first), Some(last)) if last.0 - first.0 >= 300.0 => {
                (first.1 - last.1) / (last.0 - first.0) <= STILL_CLOSING
            }
            _ => false,
        };
        // Waited for only while it stands: judged over the last 0.3 m
        // driven, so one that has just stopped is, and one walking off
        // (people at 1–1.4 m/s) is not.
        let standing = self.seen.back().is_some_and(|last| {
            self.seen
                .iter()
                .rev()
                .find(|(a, _)| last.0 - a >= 300.0)
                .is_some_and(|first| {
                    let closing = (first.1 - last.1) / (last.0 - first.0);
                    (STAND_CLOSING..=STILL_CLOSING).contains(&closing)
                })
        });
        self.no_way = (standing && past.is_some() && lo > hi).then_some(echo_mm);
        if let Some(ahead) = past.filter(|_| still) {
            // Nothing fits between: waited for a while (`Hallway::step`),
            // then left to the safe threshold, as before.
            self.lane = (lo <= hi).then(|| {
                // No farther off the middle than the pass needs.
                let lane = 0.0_f64.clamp(lo, hi);
                (lane, along_mm + ahead + ROBOT_RADIUS_MM + 300.0)
            });
        }
        match self.lane {
            Some((_, until)) if along_mm >= until => self.lane = None,
            _ => {}
        }
        self.lane.map(|(lane, _)| lane)
    }

    /// From the last scan: how near something standing still is, mm from
    /// the skin, when no lane between the walls passes it.
    pub fn no_way(&self) -> Option<f64> {
        self.no_way
    }
}

/// The Corner state's stop-and-go turn in place, degrees per second.
const SPIN_DEG_S: f64 = 8.0;

/// How near the goal direction the Corner state goes on past a side
/// detector that is lit ([`NavConfig::corner_creeps`]), degrees.
const CREEP_WITHIN_DEG: f64 = 20.0;

/// How far ahead the way must be clear for the Corner state to go on
/// past a lit side detector, mm from the robot's middle.
const CREEP_CLEAR_AHEAD_MM: f64 = 1_000.0;

/// How much wider than the robot the way must be clear, either side, mm.
const CREEP_CLEAR_SIDE_MM: f64 = 150.0;

/// Whether the way ahead is clear to go on ([`NavConfig::corner_creeps`]):
/// no sonar within 75° of ahead hears anything in the strip the robot
/// would sweep over the next [`CREEP_CLEAR_AHEAD_MM`], widened by
/// [`CREEP_CLEAR_SIDE_MM`] either side. A wall alongside is beside the
/// way; a robot at a slant ahead is on it.
fn way_clear(sonar_mm: &[u32]) -> bool {
    sonar_mm.iter().enumerate().all(|(i, &r)| {
        let b = bearing(i);
        let r = f64::from(r);
        if b.abs() > 75.0 || r >= rome_schema::robot::body::SONAR_MAX_MM {
            return true;
        }
        let d = ROBOT_RADIUS_MM + r;
        let (ahead, across) = (d * b.to_radians().cos(), d * b.to_radians().sin());
        ahead >= CREEP_CLEAR_AHEAD_MM || across.abs() >= ROBOT_RADIUS_MM + CREEP_CLEAR_SIDE_MM
    })
}

/// How far off the goal direction the Corner state ever turns, degrees.
const SPIN_BOUND_DEG: f64 = 90.0;

/// The Corner state (§5.4.2): a narrow window of sonars toward the goal
/// direction, infrared stop-and-go. Like Center-Hallway, when the window's
/// open direction is the goal direction itself and both walls are in view,
/// the walls steer (`walls`, fed with the distance driven `along_mm`).
pub fn corner_step(
    cfg: &NavConfig,
    scan: &Scan,
    heading_deg: f64,
    goal_deg: f64,
    walls: &mut Walls,
    along_mm: f64,
) -> Drive {
    let err = normalize_deg(goal_deg - heading_deg);
    let by_walls = walls.steer(&scan.sonar_mm, 0.0, along_mm, heading_deg);
    // Forward-looking infrared detectors are slots 0–3, looking 45° and 15°
    // right, then 15° and 45° left. On a detection: stop, and turn slowly
    // away from the side that sees something (toward the goal direction
    // when both do), the same way until they are clear.
    let ir = |i: usize| scan.ir_lit(i);
    let (right, left) = (ir(0) || ir(1), ir(2) || ir(3));
    if right || left {
        // Beyond the thesis: turned to within 20° of the goal direction
        // with only a 45° detector lit and the strip ahead clear, what it
        // sees is beside the way, not on it: the robot goes on, bearing
        // away from it. Spinning on carried a robot past the goal
        // direction with a wall lit on one side and a robot behind, back
        // and forth for minutes (docs/traffic.md, "Spinning in a
        // corridor's mouth").
        if cfg.corner_creeps
            && !(ir(1) || ir(2))
            && right != left
            && err.abs() <= CREEP_WITHIN_DEG
            && way_clear(&scan.sonar_mm)
        {
            walls.spin = None;
            let away = if right { 1.0 } else { -1.0 };
            return Drive::Jog(away * JOG_RATE_DEG_S);
        }
        let rate = walls.spin.get_or_insert(match (right, left) {
            (true, false) => SPIN_DEG_S,
            (false, true) => -SPIN_DEG_S,
            _ if err >= 0.0 => SPIN_DEG_S,
            _ => -SPIN_DEG_S,
        });
        // Beyond the thesis: the turn away never goes past a right angle
        // to the goal direction; there it turns back. Among robots, one
        // passing close beside kept the detectors lit, and then the wall
        // the turn swung towards: a robot turned 200° in place and drove
        // off the wrong way along the corridor.
        if err.abs() >= SPIN_BOUND_DEG && rate.signum() != err.signum() {
            *rate = -*rate;
        }
        return Drive::Spin(*rate);
    }
    walls.spin = None;
    // Beyond the thesis: clear of the detectors with a robot or a wall
    // beside it nearer than the side sonars can follow, the robot bears
    // away from it before the walls or the goal steer. A robot that had
    // spun in place beside one standing idle set off turning towards it
    // and touched it (docs/traffic.md, "Setting off beside a robot").
    if let Some(away) = corner_side_touch(&scan.sonar_mm).filter(|_| cfg.corner_bears_off) {
        return Drive::Jog(away * SIDE_TOUCH_JOG_DEG_S);
    }
    let open = open_sonar(&scan.sonar_mm, heading_deg, goal_deg, 1);
    let delta = if open != sonar_towards(err) {
        bearing(open)
    } else {
        by_walls.unwrap_or(err)
    };
    if delta.abs() < 1.0 {
        Drive::Go(cfg.corner_mm_s)
    } else {
        Drive::Jog(delta.signum() * JOG_RATE_DEG_S)
    }
}

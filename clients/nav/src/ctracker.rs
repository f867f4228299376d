//! The ceiling-light tracker, CTracker (§5.6).
//!
//! Child trackers, one per upward camera, read three scan lines of each
//! grab (at ¼, ½ and ¾ of the image height) and look for strong edges: a
//! light is in a line when some pixel's gradient exceeds a threshold. A
//! child that sees a light appear takes the token `$LightToken` before it
//! reports it, and gives the token back when the light has gone, so a light
//! two children see is counted once.
//!
//! The parent checks each report against the map: the distance travelled
//! since the last light must agree with the next entry of `LightOffset`.
//! Only valid lights are counted in `CeilingLight`. After the segment's last
//! light it writes `Overshoot` (how far past that light the robot is) and
//! signals `$EndLMode`. A light not seen by the time the robot is well past
//! where the map puts it is counted by distance and logged as missed, so a
//! missed light costs accuracy, not the run.

use crate::board::{Board, Sem, Var, PLANNER_PATIENCE};
use crate::navigator::Pose;
use crate::NavError;
use rome_client::{ClientError, RobotClient};
use rome_maps::geometry::direction;
use std::time::Duration;
use tokio::sync::mpsc;

/// Ceiling covered along the robot by the upward image, mm (§5.6: about
/// 1.2 × 1.5 m).
pub const VIEW_ALONG_MM: f64 = 1_200.0;

/// How the tracker works.
#[derive(Debug, Clone, PartialEq)]
pub struct TrackConfig {
    /// The child trackers' cameras (the same camera twice runs two children
    /// on one image stream, which the token keeps from double counting).
    pub cameras: Vec<String>,
    /// Gradient (grey levels over three pixels) that makes an edge.
    pub edge: i16,
    /// A light is valid if the distance travelled since the last one is
    /// within this fraction of the map's distance …
    pub tolerance: f64,
    /// … or within this many mm, whichever is larger.
    pub tolerance_mm: f64,
    /// How often the parent checks whether a light was missed.
    pub check_every: Duration,
}

impl Default for TrackConfig {
    fn default() -> Self {
        TrackConfig {
            cameras: vec!["up".into()],
            edge: 60,
            tolerance: 0.25,
            tolerance_mm: 1_200.0,
            check_every: Duration::from_millis(100),
        }
    }
}

/// Whether a scan line crosses the edge of a light: some gradient over
/// three pixels of at least `edge` grey levels.
pub fn line_has_light(row: &[u8], edge: i16) -> bool {
    row.windows(4)
        .any(|w| (i16::from(w[3]) - i16::from(w[0])).abs() >= edge)
}

/// The three scan lines of an image `height` rows high.
pub fn scan_lines(height: u32) -> [u32; 3] {
    [height / 4, height / 2, height * 3 / 4]
}

/// Where the light's centre is along the robot, mm ahead of the camera,
/// from which of the three lines (ahead, middle, behind) see it. A light is
/// half the view long, so it spans two neighbouring lines at most.
pub fn light_ahead_mm(lines: [bool; 3]) -> Option<f64> {
    let q = VIEW_ALONG_MM / 4.0;
    match lines {
        [true, false, false] => Some(1.5 * q),
        [true, true, false] => Some(0.5 * q),
        [true, true, true] | [false, true, false] => Some(0.0),
        [false, true, true] => Some(-0.5 * q),
        [false, false, true] => Some(-1.5 * q),
        _ => None,
    }
}

/// A child's report: a light in view, where the robot was, and how far
/// ahead of it the light's centre lay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Sighting {
    /// Which child.
    pub child: usize,
    /// The frame.
    pub frame: u64,
    /// The robot's odometry pose when the frame was read.
    pub pose: Pose,
    /// The light's centre, mm ahead of the camera.
    pub ahead_mm: f64,
}

/// The parent's verdict on a sighting, given how far the robot has
/// travelled since the last light and how far the map says it should.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Verdict {
    /// Counted.
    Valid,
    /// Too early: a false light, or the last one seen again.
    TooEarly,
    /// Too late for the next light: the robot has gone past it unseen.
    TooLate,
}

/// Judges a distance travelled against the map's.
pub fn judge(cfg: &TrackConfig, travelled: f64, expected: f64) -> Verdict {
    let tol = (expected * cfg.tolerance).max(cfg.tolerance_mm);
    if travelled < expected - tol {
        Verdict::TooEarly
    } else if travelled > expected + tol {
        Verdict::TooLate
    } else {
        Verdict::Valid
    }
}

/// Whether a sighting `since` mm past the place where a light was just
/// counted by distance is that light, seen late: nearer to it than to the
/// next one, `next_mm` further on. Odometry that ran ahead of the robot (its
/// wheels turned while something held it) puts every later light that much
/// further on; measuring from the late sighting takes the drift out, where
/// measuring from the place counted would miss every light after it.
pub fn seen_late(cfg: &TrackConfig, since: f64, next_mm: f64) -> bool {
    since > -cfg.tolerance_mm && since < next_mm / 2.0
}

/// What the tracker did in one L segment; written to the board's
/// `TrackLog` before up($EndLMode), so the Planner can judge the segment.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct SegmentLog {
    /// Lights the segment has.
    pub lights: usize,
    /// Lights counted from sightings.
    pub seen: usize,
    /// Lights counted by distance after being missed.
    pub missed: usize,
    /// Sightings refused by the parent.
    pub refused: usize,
    /// Overshoot reported, mm.
    pub overshoot_mm: f64,
    /// Whether the last light was counted by distance: the segment ended
    /// on odometry alone.
    pub last_missed: bool,
    /// Whether the segment's first light was counted by distance, not
    /// seen (§6.3's p5 asks how often the first light after a corner is
    /// found).
    #[serde(default)]
    pub first_missed: bool,
    /// Lights counted by distance and then seen late, from which the next
    /// light was measured (odometry had run ahead of the robot).
    #[serde(default)]
    pub found_late: usize,
}

/// Where an L segment stands, on the blackboard (`Tracking`) after every
/// light: a CTracker killed in the middle of a segment and started again
/// takes it up from here instead of waiting for the next one, which
/// would leave the Navigator waiting for a count that never comes.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Tracking {
    /// Whether the segment is still being counted.
    pub open: bool,
    /// The segment: the history number of the `LightOffset` the Planner
    /// wrote for it, so a segment of a run that has ended since is not
    /// taken up.
    pub segment: u64,
    /// Lights counted.
    pub count: usize,
    /// Where the last counted light was (or the segment began), mm along
    /// the segment's heading in odometry.
    pub last_mm: f64,
    /// The segment's log so far.
    pub log: SegmentLog,
}

impl SegmentLog {
    /// Why the segment failed, if it did: the robot lost the lights (more
    /// than a third missed) or the segment ended on distance alone.
    pub fn failure(&self) -> Option<String> {
        if self.lights == 0 {
            return None;
        }
        if self.missed * 3 > self.lights {
            Some(format!(
                "lost the lights: {} of {} missed",
                self.missed, self.lights
            ))
        } else if self.last_missed {
            Some("ended on distance alone: the last light was not seen".into())
        } else {
            None
        }
    }
}

/// Checks of the light clock between two looks for a new segment handed
/// in the middle of one (at the default 100 ms, every second).
const NEW_SEGMENT_EVERY: u32 = 10;

/// The tracker of one robot.
pub struct CTracker {
    robot: RobotClient,
    board: Board,
    cfg: TrackConfig,
}

impl CTracker {
    /// A tracker.
    pub fn new(robot: RobotClient, board: Board, cfg: TrackConfig) -> CTracker {
        CTracker { robot, board, cfg }
    }

    /// Runs the children and the parent until a client call fails; each
    /// finished segment is sent to `log` (if given).
    pub async fn run(
        &self,
        log: Option<mpsc::UnboundedSender<SegmentLog>>,
    ) -> Result<(), NavError> {
        self.board.declare().await?;
        let (tx, mut rx) = mpsc::channel::<Sighting>(64);
        let mut children = tokio::task::JoinSet::new();
        for (i, camera) in self.cfg.cameras.iter().enumerate() {
            let child = Child {
                id: i,
                robot: self.robot.clone(),
                board: self.board.clone(),
                camera: camera.clone(),
                edge: self.cfg.edge,
            };
            let tx = tx.clone();
            children.spawn(rome_clock::wrap("ctracker child", async move {
                child.run(tx).await
            }));
        }
        drop(tx);
        let mut resume = self.left_open().await?;
        // A segment handed while the one before was still counted.
        let mut handed = false;
        loop {
            tokio::select! {
                biased;
                Some(done) = children.join_next() => {
                    return match done {
                        Ok(Err(e)) => Err(e),
                        _ => Err(NavError::Gone("a ceiling-light child tracker stopped")),
                    };
                }
                seg = self.segment(&mut rx, resume.take(), std::mem::take(&mut handed)) => {
                    let (seg, next) = seg?;
                    handed = next;
                    tracing::info!(?seg, "ctracker: segment done");
                    if let Some(log) = &log {
                        let _ = log.send(seg);
                    }
                }
            }
        }
    }

    async fn pose(&self) -> Result<Pose, NavError> {
        Ok(Pose::from(&crate::track::pose_waiting(&self.robot).await?))
    }

    /// A segment a CTracker before this one left open, if it is still the
    /// Planner's latest and a Planner waits for the goal or the segment's
    /// end.
    async fn left_open(&self) -> Result<Option<Tracking>, NavError> {
        let t = match self.board.get::<Option<Tracking>>(Var::Tracking).await {
            Ok(Some(t)) if t.open => t,
            Ok(_) => return Ok(None),
            // Never written: no CTracker has tracked for this robot yet.
            Err(e) if e.code() == Some(rome_schema::ErrorCode::UnknownVariable) => return Ok(None),
            Err(e) if crate::bad_value(&e) => {
                tracing::warn!(error = %e, "ctracker: Tracking does not decode; ignored");
                return Ok(None);
            }
            Err(e) => return Err(e.into()),
        };
        let latest = self.segment_seq().await?;
        // As patient as the Navigator: a tracker that gave the segment up
        // while the Navigator took its goal up would leave the robot
        // driving past lights nobody counts.
        let waits = t.segment == latest
            && self
                .board
                .someone_waits(&[Sem::RobotStatus, Sem::EndLMode], PLANNER_PATIENCE)
                .await?;
        if waits {
            tracing::info!(count = t.count, "ctracker: taking up the segment left open");
            Ok(Some(t))
        } else {
            tracing::info!("ctracker: a segment was left open, but it is over");
            self.board.set(Var::Tracking, &None::<Tracking>).await?;
            Ok(None)
        }
    }

    /// The history number of the segment's `LightOffset`.
    async fn segment_seq(&self) -> Result<u64, NavError> {
        let name = self.board.var_name(Var::LightOffset);
        match self.board.client().history(&name).await {
            Ok(h) => Ok(h.seq),
            Err(e) if crate::bad_value(&e) => Ok(0),
            Err(e) => Err(e.into()),
        }
    }

    /// One L segment: down($TrackData) … up($EndLMode), or the rest of one
    /// taken up.
    /// `handed`: its `$TrackData` was taken already. Also returns whether
    /// the segment was left for a new one handed before it ended (a run
    /// ended and the next began), whose `$TrackData` is taken.
    async fn segment(
        &self,
        rx: &mut mpsc::Receiver<Sighting>,
        resume: Option<Tracking>,
        handed: bool,
    ) -> Result<(SegmentLog, bool), NavError> {
        if resume.is_none() && !handed {
            self.board.down(Sem::TrackData).await?;
        }
        let (goal, offsets, heading) = match self.segment_values().await? {
            Ok(values) => values,
            Err(why) => {
                // Anyone may write the blackboard: a bad value gives this
                // segment up, with the reason where the Navigator reads
                // the count, and the tracker waits for the next one.
                tracing::warn!("ctracker: segment given up: {why}");
                self.board.set(Var::Tracking, &None::<Tracking>).await?;
                self.board
                    .set(Var::CeilingLight, &crate::board::GaveUp { failed: why })
                    .await?;
                return Ok((SegmentLog::default(), false));
            }
        };
        // Sightings from before the segment are stale.
        while rx.try_recv().is_ok() {}
        let axis = direction(heading);
        let along = |p: &Pose| p.at.x * axis.x + p.at.y * axis.y;
        let total = usize::try_from(goal).unwrap_or(0).min(offsets.len());
        let segment = self.segment_seq().await?;
        let (mut last, mut count, mut log) = match resume {
            Some(t) => (t.last_mm, t.count.min(total), t.log),
            None => {
                self.board
                    .set(Var::CountedAt, &None::<crate::board::CountedAt>)
                    .await?;
                self.board.set(Var::CeilingLight, &0i64).await?;
                let log = SegmentLog {
                    lights: total,
                    ..SegmentLog::default()
                };
                (along(&self.pose().await?), 0, log)
            }
        };
        let mut tracking = Tracking {
            open: true,
            segment,
            count,
            last_mm: last,
            log: log.clone(),
        };
        self.board.set(Var::Tracking, &Some(&tracking)).await?;
        if count > 0 {
            // Taken up: the count the tracker before may not have said.
            if count == total {
                self.counted(count, total, last, &mut log, along).await?;
            } else {
                self.board.set(Var::CeilingLight, &(count as i64)).await?;
            }
        }
        let mut tick = rome_clock::interval(self.cfg.check_every);
        let mut ticks = 0u32;
        while count < total {
            let expected = offsets[count];
            tokio::select! {
                biased;
                s = rome_clock::idle(rx.recv()) => {
                    let Some(s) = s else {
                        return Err(NavError::Gone("every ceiling-light child tracker stopped"));
                    };
                    let at = along(&s.pose) + s.ahead_mm;
                    match judge(&self.cfg, at - last, expected) {
                        Verdict::Valid => {
                            count += 1;
                            log.seen += 1;
                            log.last_missed = false;
                            last = at;
                            self.keep(&mut tracking, count, last, &log).await?;
                            self.counted(count, total, last, &mut log, along).await?;
                        }
                        Verdict::TooEarly if log.last_missed && seen_late(&self.cfg, at - last, expected) => {
                            log.last_missed = false;
                            log.found_late += 1;
                            tracing::info!(light = count, late_mm = at - last, "ctracker: a light counted by distance was seen late; the next is measured from it");
                            last = at;
                        }
                        Verdict::TooEarly | Verdict::TooLate => {
                            log.refused += 1;
                            tracing::debug!(travelled = at - last, expected, "ctracker: sighting refused");
                        }
                    }
                }
                _ = tick.tick() => {
                    ticks += 1;
                    if ticks.is_multiple_of(NEW_SEGMENT_EVERY) && self.new_segment_handed().await? {
                        tracing::info!(count, total, "ctracker: a new segment came before this one ended; it is left");
                        self.board.set(Var::Tracking, &None::<Tracking>).await?;
                        return Ok((log, true));
                    }
                    let now = along(&self.pose().await?);
                    if judge(&self.cfg, now - last, expected) == Verdict::TooLate {
                        count += 1;
                        log.missed += 1;
                        log.last_missed = true;
                        log.first_missed |= count == 1;
                        last += expected;
                        tracing::warn!(light = count, "ctracker: light missed; counted by distance");
                        self.keep(&mut tracking, count, last, &log).await?;
                        self.counted(count, total, last, &mut log, along).await?;
                    }
                }
            }
        }
        if total == 0 {
            self.board.set(Var::Overshoot, &0i64).await?;
            self.board.set(Var::TrackLog, &log).await?;
            self.board.up(Sem::EndLMode).await?;
        }
        // Closed: the segment's end is said.
        self.board.set(Var::Tracking, &None::<Tracking>).await?;
        Ok((log, false))
    }

    /// A try-wait on `$TrackData` in the middle of a segment. The Planner
    /// hands the next segment only after `$EndLMode`, so one here means
    /// the run that handed the segment at hand has ended: counting on
    /// would count the next run's lights as this one's.
    async fn new_segment_handed(&self) -> Result<bool, NavError> {
        let sem = self.board.sem_name(Sem::TrackData);
        Ok(self.board.client().try_wait(&sem).await?)
    }

    /// The segment's light count, light offsets and heading; a bad value
    /// ([`crate::bad_value`]) is `Err` with the reason, anything else that fails
    /// (the data server gone) the outer error.
    async fn segment_values(&self) -> Result<Result<(i64, Vec<f64>, f64), String>, NavError> {
        fn read<T>(r: Result<T, ClientError>, what: &str) -> Result<Result<T, String>, NavError> {
            match r {
                Ok(v) => Ok(Ok(v)),
                Err(e) if crate::bad_value(&e) => Ok(Err(format!("{what} could not be read: {e}"))),
                Err(e) => Err(e.into()),
            }
        }
        let goal = read(
            self.board.get(Var::GoalDistance).await,
            "the segment's light count (GoalDistance)",
        )?;
        let offsets = read(
            self.board.get(Var::LightOffset).await,
            "the segment's light offsets (LightOffset)",
        )?;
        let heading = read(
            self.board.get(Var::GoalDirection).await,
            "the segment's heading (GoalDirection)",
        )?;
        Ok(match (goal, offsets, heading) {
            (Ok(g), Ok(o), Ok(h)) => Ok((g, o, h)),
            (Err(why), _, _) | (_, Err(why), _) | (_, _, Err(why)) => Err(why),
        })
    }

    /// Keeps where the segment stands on the blackboard, before the count
    /// is said: a tracker killed in between says it again when it takes
    /// the segment up.
    async fn keep(
        &self,
        tracking: &mut Tracking,
        count: usize,
        last: f64,
        log: &SegmentLog,
    ) -> Result<(), NavError> {
        tracking.count = count;
        tracking.last_mm = last;
        tracking.log.clone_from(log);
        Ok(self.board.set(Var::Tracking, &Some(&*tracking)).await?)
    }

    async fn counted(
        &self,
        count: usize,
        total: usize,
        light_at: f64,
        log: &mut SegmentLog,
        along: impl Fn(&Pose) -> f64,
    ) -> Result<(), NavError> {
        if count == total {
            let at = self.pose().await?;
            let overshoot = along(&at) - light_at;
            log.overshoot_mm = overshoot;
            self.board
                .set(Var::Overshoot, &(overshoot.round() as i64))
                .await?;
            // Said before the count, so a Navigator that reads the count
            // finds where the overshoot was taken.
            let counted_at = crate::board::CountedAt {
                x_mm: at.at.x,
                y_mm: at.at.y,
            };
            self.board.set(Var::CountedAt, &Some(counted_at)).await?;
        }
        self.board.set(Var::CeilingLight, &(count as i64)).await?;
        self.board.up(Sem::LightDet).await?;
        if count == total {
            self.board.set(Var::TrackLog, &*log).await?;
            self.board.up(Sem::EndLMode).await?;
        }
        Ok(())
    }
}

/// A child tracker: one camera's frames, three scan lines each.
struct Child {
    id: usize,
    robot: RobotClient,
    board: Board,
    camera: String,
    edge: i16,
}

impl Child {
    async fn run(self, tx: mpsc::Sender<Sighting>) -> Result<(), NavError> {
        let track = crate::track::PoseTrack::start(&self.robot).await?;
        let frames = self.robot.frames(&self.camera).await?;
        let size = self.robot.camera_size(&self.camera).await?;
        let rows = scan_lines(size.height);
        let (mut lit_before, mut holding, mut reported) = (false, false, false);
        while let Some(frame) = frames.next().await {
            // A frame that cannot be read, or whose pose cannot be had (the
            // robot's servers restarting), is skipped: the next frames come
            // once they are back, and the segment goes on.
            let read = async {
                let frame = frame?;
                let img = self.robot.camera_rows(&self.camera, &rows).await?;
                // Where the rows' image was grabbed, not where the robot is now.
                let pose = track.at(&self.robot, img.time_ms).await?;
                Ok::<_, NavError>((frame, img, pose))
            };
            let (frame, img, pose) = match read.await {
                Ok(read) => read,
                Err(e) => {
                    tracing::warn!(camera = %self.camera, error = %e, "ctracker: a frame skipped");
                    continue;
                }
            };
            // camera_rows checked the reply carries the three rows asked for.
            let lines = [0, 1, 2].map(|k| img.row(k).is_some_and(|r| line_has_light(r, self.edge)));
            let lit = lines.iter().any(|l| *l);
            if lit && !lit_before {
                // With undo: a tracker killed while a light is in view
                // must not take the token with it, or no light would ever
                // be reported again.
                holding = self.board.try_down_undo(Sem::LightToken).await?;
                reported = false;
            }
            if lit && holding && !reported && (lines[1] || lines[2]) {
                if let Some(ahead_mm) = light_ahead_mm(lines) {
                    reported = true;
                    let s = Sighting {
                        child: self.id,
                        frame: frame.frame,
                        pose,
                        ahead_mm,
                    };
                    // Never wait for the parent: between L segments it
                    // reads nothing (it waits for $TrackData and then
                    // drops what came before as stale), and a child
                    // waiting on a full queue would stop its frames and,
                    // in lock-step, the clock.
                    match tx.try_send(s) {
                        Ok(()) | Err(mpsc::error::TrySendError::Full(_)) => {}
                        Err(mpsc::error::TrySendError::Closed(_)) => break,
                    }
                }
            }
            if !lit && lit_before && holding {
                give_back(&self.board).await?;
                holding = false;
            }
            lit_before = lit;
        }
        if holding {
            give_back(&self.board).await?;
        }
        Ok(())
    }
}

/// Gives the light token back. A data server that restarted while the
/// token was held has taken it back already (its holder's token seemed
/// gone), and says `conflict`: the token is back either way.
async fn give_back(board: &Board) -> Result<(), NavError> {
    match board.give_back(Sem::LightToken).await {
        Err(e) if e.code() == Some(rome_schema::ErrorCode::Conflict) => {
            tracing::warn!(error = %e, "ctracker: the light token was back already");
            Ok(())
        }
        other => Ok(other?),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_edge_is_a_strong_gradient() {
        let mut row = vec![60u8; 100];
        assert!(!line_has_light(&row, 60));
        // Pixel noise is not an edge.
        for (i, p) in row.iter_mut().enumerate() {
            *p = 60 + (i % 7) as u8 * 3;
        }
        assert!(!line_has_light(&row, 60));
        for p in &mut row[40..80] {
            *p = 235;
        }
        assert!(line_has_light(&row, 60));
    }

    #[test]
    fn the_three_lines_place_the_light_along_the_robot() {
        assert_eq!(scan_lines(482), [120, 241, 361]);
        assert_eq!(light_ahead_mm([true, false, false]), Some(450.0));
        assert_eq!(light_ahead_mm([true, true, false]), Some(150.0));
        assert_eq!(light_ahead_mm([false, true, true]), Some(-150.0));
        assert_eq!(light_ahead_mm([false, false, true]), Some(-450.0));
        assert_eq!(light_ahead_mm([true, false, true]), None);
        assert_eq!(light_ahead_mm([false, false, false]), None);
    }

    #[test]
    fn the_parent_accepts_lights_where_the_map_puts_them() {
        let cfg = TrackConfig::default();
        assert_eq!(judge(&cfg, 5_900.0, 6_000.0), Verdict::Valid);
        assert_eq!(judge(&cfg, 7_400.0, 6_000.0), Verdict::Valid);
        assert_eq!(judge(&cfg, 2_000.0, 6_000.0), Verdict::TooEarly);
        assert_eq!(judge(&cfg, 7_600.0, 6_000.0), Verdict::TooLate);
        // Short distances get the absolute tolerance.
        assert_eq!(judge(&cfg, 2_100.0, 1_000.0), Verdict::Valid);
    }
}

//! One task driven ([`OnDuty::carry_out`]): planned from where the robot
//! stands, driven by the Planner while what runs beside it
//! ([`super::watch`], [`super::way`]) may end it early, and judged at the
//! end.

use super::aside::LastLeg;
use super::duty::{Aside, DutyConfig, DutyNote, OnDuty};
use super::schema::{way_var, Assignment, Outcome, WayAsk};
use crate::board::GoalType;
use crate::plan::Plan;
use crate::planner::{self, Progress};
use rome_maps::geometry::Point;
use std::sync::atomic::Ordering::Relaxed;

/// Whether `plan`'s first leg runs along a corridor whose axis is
/// `axis_deg` (either way), within [`ALONG_AXIS_DEG`].
fn leaves_along(plan: &Plan, axis_deg: f64) -> bool {
    plan.route.legs().first().is_none_or(|&(_, _, _, h)| {
        let off = rome_maps::geometry::normalize_deg(h - axis_deg).abs();
        off.min(180.0 - off) <= ALONG_AXIS_DEG
    })
}

/// How far a first leg may turn from the corridor a robot stood aside in
/// and still be driven from the point its position names, degrees.
const ALONG_AXIS_DEG: f64 = 20.0;

impl OnDuty<'_> {
    /// Drives one task: how it went, and where the robot stands after it
    /// (`None`: nowhere the map names). With `cancellable`, it stops when
    /// the robot's `Task` no longer names `a`, and (making way on) asks
    /// robots in its way to make way; without, as when it makes way
    /// itself, it asks nobody, so that asks do not pass on from robot to
    /// robot making way into a knot.
    pub(super) async fn carry_out(
        &self,
        cfg: &DutyConfig,
        (from, aside): (&(String, Option<Point>), Option<Aside>),
        a: &Assignment,
        cancellable: bool,
        (registered, facing, last_leg): (&mut bool, &mut Option<f64>, &mut Option<LastLeg>),
        note: &mut impl FnMut(DutyNote<'_>),
    ) -> (Outcome, Option<String>) {
        let outcome = |ok: bool, why: Option<String>| Outcome {
            task: a.task.clone(),
            ok,
            why,
        };
        let (label, point) = from;
        if point.is_none() && *label == a.to && a.via.is_empty() {
            return (outcome(true, None), Some(label.clone()));
        }
        let planned = match (point, aside) {
            (Some(p), _) => Plan::from_point(self.world, self.network, (label, *p), &a.via, &a.to),
            // Stood aside, up to half a corridor's width off the point its
            // position names. A route that leaves along the corridor is
            // driven as planned: the Navigator centres the robot on the
            // way. One that turns off at once, planned from that point and
            // driven from where the robot stands, would run on a slant
            // across the corridor into the end of a wall: it is planned
            // from where the robot stands.
            (None, Some((q, axis))) => {
                let named = Plan::through(self.world, self.network, label, &a.via, &a.to);
                match named {
                    Ok(p) if leaves_along(&p, axis) => Ok(p),
                    _ => Plan::from_point(self.world, self.network, (label, q), &a.via, &a.to)
                        .or(named),
                }
            }
            (None, None) => Plan::through(self.world, self.network, label, &a.via, &a.to),
        };
        let plan = match planned {
            Ok(p) => p.keeping(&cfg.rules),
            // Not moved: it still stands where it stood.
            Err(e) => {
                let still = point.is_none().then(|| label.clone());
                return (outcome(false, Some(e.to_string())), still);
            }
        };
        // Only a robot standing off every named position is let back up.
        if let (Some(_), [p, q, ..]) = (point, plan.route.points.as_slice()) {
            if self.network.against(*p, *q) {
                tracing::info!(
                    robot = self.name,
                    to = a.to,
                    mm = rome_maps::geometry::distance(*p, *q),
                    "backs up to its goal against a one-way stretch"
                );
            }
        }
        note(DutyNote::Took(a, &plan));
        // Set while the Planner waits its turn: standing still is not being
        // blocked then.
        let waiting = std::sync::atomic::AtomicBool::new(false);
        // Set once it asked robots in its way to make way.
        let asked = std::sync::atomic::AtomicBool::new(false);
        let drive = async {
            if *registered {
                let heading = self.robot.pose().await?.heading_deg;
                planner::turn_onto(self.robot, &plan, heading).await?;
            } else {
                planner::put_down(self.robot, &plan, facing.take()).await?;
                *registered = true;
            }
            planner::run(self.board, &plan, self.truth, |p| {
                match p {
                    Progress::Waiting(_) => waiting.store(true, Relaxed),
                    Progress::Holding(_, true) => waiting.store(false, Relaxed),
                    _ => {}
                }
                note(DutyNote::Planner(p))
            })
            .await
        };
        let ended = tokio::select! {
            biased;
            r = drive => r.map(|_| ()).map_err(|e| format!("the Planner stopped: {e}")),
            why = self.cancelled(a, cfg.check_every), if cancellable => Err(why),
            why = self.blocked(cfg, &waiting) => Err(why),
            why = self.overdue(cfg, &waiting, plan.route.length_mm) => Err(why),
            never = self.ask_way(cfg, (&waiting, &asked), &plan.route), if cfg.rules.make_way && cancellable => match never {},
        };
        if asked.load(Relaxed) {
            let _ = (self.board.client())
                .set(&way_var(self.name), &None::<WayAsk>)
                .await;
        }
        if let Err(why) = ended {
            // Stopped where it is, holding nothing of the building.
            let _ = self.robot.stop(false).await;
            let _ = planner::give_back_all(self.board).await;
            if !matches!(
                planner::stop_navigator(self.board, self.robot).await,
                Ok(true)
            ) {
                tracing::warn!(robot = self.name, "the Navigator did not take its stop");
            }
            return (outcome(false, Some(why)), None);
        }
        let (_, goal) = plan.ends();
        *last_leg = plan
            .steps
            .last()
            .filter(|s| s.goal.goal_type == GoalType::D)
            .and_then(|s| Some((s.goal.direction_deg, s.goal_walls_mm?)));
        match self.judged(a, goal).await {
            None => (outcome(true, None), Some(a.to.clone())),
            why => (outcome(false, why), None),
        }
    }

    /// Whether the robot is at `goal`, `a`'s goal, by ground truth where
    /// a simulator answers (`None`: it is), else by the Navigator's word.
    async fn judged(&self, a: &Assignment, goal: Point) -> Option<String> {
        let p = self.truth?.get().await.ok()?;
        let off_mm = (p.x_mm - goal.x).hypot(p.y_mm - goal.y);
        (off_mm > crate::report::ARRIVED_CM * 10.0)
            .then(|| format!("ended {:.2} m from {}", off_mm / 1000.0, a.to))
    }
}

//! The one place where a [`Pose`] meets the wire's unit-suffixed fields
//! (`x_mm`, `y_mm`, `heading_deg`): the base's pose reply and state, and
//! the simulator's ground truth.

use crate::geometry::Pose;
use rome_schema::robot::{BaseState, PoseReply};
use rome_schema::sim::{ContactCount, Truth};

impl From<&PoseReply> for Pose {
    fn from(p: &PoseReply) -> Pose {
        Pose::new(f64::from(p.x_mm), f64::from(p.y_mm), p.heading_deg)
    }
}

impl From<&BaseState> for Pose {
    fn from(s: &BaseState) -> Pose {
        Pose::new(f64::from(s.x_mm), f64::from(s.y_mm), s.heading_deg)
    }
}

impl From<&Truth> for Pose {
    fn from(t: &Truth) -> Pose {
        Pose::new(t.x_mm, t.y_mm, t.heading_deg)
    }
}

/// Robot `robot`'s ground truth at `time_ms` as sent on the wire.
pub fn truth(
    robot: &str,
    time_ms: u64,
    pose: &Pose,
    travelled_mm: f64,
    contacts: ContactCount,
) -> Truth {
    Truth {
        robot: robot.to_string(),
        time_ms,
        x_mm: pose.at.x,
        y_mm: pose.at.y,
        heading_deg: pose.heading.deg(),
        travelled_mm,
        contacts,
        floor: None,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Heading;

    #[test]
    fn a_pose_survives_the_wire_both_ways() {
        let p = Pose::new(-4_210.5, 10_480.25, 90.5);
        let t = truth("r1", 5, &p, 0.0, ContactCount::default());
        assert_eq!((t.x_mm, t.y_mm, t.heading_deg), (-4_210.5, 10_480.25, 90.5));
        assert_eq!(Pose::from(&t), p);
        assert_eq!(p.heading, Heading::from_deg(90.5));
    }
}

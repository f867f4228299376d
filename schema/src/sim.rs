//! The simulator's own keys: ground truth, which no real robot has.
//!
//! ```text
//! rome/sim/<robot>/truth     where a robot truly is (query, and a stream)
//! rome/sim/clock             simulated time (a stream, like ROS's /clock)
//! rome/sim/clock/party/<id>  liveliness: a process following a lock-step clock
//! rome/sim/clock/ack/<id>    that process is done with an instant
//! ```
//!
//! Like a simulator's ground-truth topic, it is for judging runs, tests and
//! people watching, never for navigation: the navigation clients know only
//! what the hardware servers tell them.

use crate::keys::Name;
use crate::Root;
use serde::{Deserialize, Serialize};

/// Simulator → anyone: simulated time, ten times a simulated second
/// (every instant in lock-step).
///
/// In lock-step an instant is settled in rounds. Round 0 moves time on;
/// every later round repeats the instant with the parties that must
/// answer it, until a round in which nobody had anything more to do: a
/// message one follower sent another is then handled at the instant it
/// was sent, wherever the two run.
///
/// ```text
/// rome/sim/clock
/// {"time_ms":61500,"lockstep":true}
/// {"time_ms":61500,"lockstep":true,"round":1,"parties":["2f0c…","9a1e…"]}
/// {"time_ms":61500,"lockstep":true,"round":2,"parties":["2f0c…","9a1e…"],"release":true}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Clock {
    /// Simulated time, ms.
    pub time_ms: u64,
    /// Whether the world steps only when every participant is done with
    /// the present instant (else it is paced against the wall clock).
    pub lockstep: bool,
    /// Which round of the instant this is (0: time has just moved on).
    #[serde(default, skip_serializing_if = "is_zero")]
    pub round: u32,
    /// In a round after the first, the parties (process ids) that answered
    /// the round before: each follower waits until it has heard all of
    /// their acknowledgements before it answers this one.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub parties: Vec<String>,
    /// Nobody had anything to do in the round before, but requests that
    /// change something wait for their round to end (some party said it
    /// was `holding` them): every process hands them to its servers now,
    /// in the same order in every run, before it answers this round.
    #[serde(default, skip_serializing_if = "is_false")]
    pub release: bool,
}

impl Clock {
    /// The first message of instant `time_ms` (round 0), in lock-step or
    /// paced against the wall clock.
    pub fn instant(time_ms: u64, lockstep: bool) -> Clock {
        Clock {
            time_ms,
            lockstep,
            round: 0,
            parties: Vec::new(),
            release: false,
        }
    }
}

/// A process following a lock-step clock → the simulator and the other
/// followers: it has finished with round `round` of the instant `time_ms`
/// (every reaction to it is sent), and whether it had anything to do
/// since its acknowledgement of the round before.
///
/// ```text
/// rome/sim/clock/ack/<id>
/// {"time_ms":61500}
/// {"time_ms":61500,"round":1,"worked":false}
/// {"time_ms":61500,"round":1,"worked":false,"holding":true}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ClockAck {
    /// The instant finished with, simulated ms.
    pub time_ms: u64,
    /// The round of the instant finished with.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub round: u32,
    /// Whether the process handled anything since its last
    /// acknowledgement (always so in round 0).
    #[serde(default = "yes")]
    pub worked: bool,
    /// Whether its servers hold requests that change something until a
    /// round with `release`.
    #[serde(default, skip_serializing_if = "is_false")]
    pub holding: bool,
}

fn is_zero(n: &u32) -> bool {
    *n == 0
}

fn is_false(b: &bool) -> bool {
    !*b
}

fn yes() -> bool {
    true
}

/// How often the clock is published, in simulated milliseconds.
pub const CLOCK_EVERY_MS: u64 = 100;

/// Simulator → anyone: a robot's true pose and what it has touched.
///
/// ```text
/// rome/sim/r1/truth
/// {"robot":"r1","time_ms":61500,"x_mm":-4210.5,"y_mm":10480.2,"heading_deg":90.4,
///  "travelled_mm":30125.0,"contacts":{"wall":0,"robot":0,"bumper":0}}
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Truth {
    /// The robot's name.
    pub robot: String,
    /// Simulated time, ms.
    pub time_ms: u64,
    /// True x (East), mm.
    pub x_mm: f64,
    /// True y (North), mm.
    pub y_mm: f64,
    /// True heading, degrees (North 0, West 90).
    pub heading_deg: f64,
    /// Distance truly driven since it was put in the world, mm.
    pub travelled_mm: f64,
    /// Touches so far.
    pub contacts: ContactCount,
    /// The floor it is on, in a world of several floors (`x_mm`, `y_mm`
    /// are then that floor's map coordinates); absent in a world of one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub floor: Option<String>,
}

/// How often a robot has come to touch something (each touch counts once).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct ContactCount {
    /// Walls, doors and other solid parts of the building.
    pub wall: u32,
    /// Other robots.
    pub robot: u32,
    /// Bumper presses.
    pub bumper: u32,
}

impl ContactCount {
    /// The touches between two counts (`later` − `self`).
    pub fn since(&self, later: &ContactCount) -> ContactCount {
        ContactCount {
            wall: later.wall.saturating_sub(self.wall),
            robot: later.robot.saturating_sub(self.robot),
            bumper: later.bumper.saturating_sub(self.bumper),
        }
    }

    /// Walls and robots together.
    pub fn total(&self) -> u32 {
        self.wall + self.robot
    }
}

impl Root {
    /// `<root>/sim/<robot>/truth`: a simulated robot's true pose.
    pub fn sim_truth(&self, robot: &Name) -> String {
        format!("{}/sim/{}/truth", self.as_str(), robot.as_str())
    }

    /// `<root>/sim/clock`: simulated time.
    pub fn sim_clock(&self) -> String {
        format!("{}/sim/clock", self.as_str())
    }

    /// `<root>/sim/clock/party/<id>`: the liveliness token of a process
    /// following a lock-step clock (it is waited for while it lives).
    pub fn sim_clock_party(&self, id: &str) -> String {
        format!("{}/sim/clock/party/{id}", self.as_str())
    }

    /// `<root>/sim/clock/party/*`: every such token.
    pub fn sim_clock_parties(&self) -> String {
        self.sim_clock_party("*")
    }

    /// `<root>/sim/clock/ack/<id>`: where party `id` says it is done with
    /// an instant.
    pub fn sim_clock_ack(&self, id: &str) -> String {
        format!("{}/sim/clock/ack/{id}", self.as_str())
    }

    /// `<root>/sim/clock/ack/*`: every party's acknowledgements.
    pub fn sim_clock_acks(&self) -> String {
        self.sim_clock_ack("*")
    }

    /// `<root>/sim/*/truth`: every simulated robot's true pose.
    pub fn sim_truth_all(&self) -> String {
        format!("{}/sim/*/truth", self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn truth_keys_and_contact_differences() {
        let root = Root::default();
        let r1 = Name::new("r1").unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(root.sim_truth(&r1), "rome/sim/r1/truth");
        assert_eq!(root.sim_truth_all(), "rome/sim/*/truth");
        assert_eq!(root.sim_clock(), "rome/sim/clock");
        assert_eq!(root.sim_clock_party("z1"), "rome/sim/clock/party/z1");
        assert_eq!(root.sim_clock_acks(), "rome/sim/clock/ack/*");
        let a: ClockAck = crate::decode(br#"{"time_ms":61510}"#, "ack").unwrap();
        assert_eq!((a.time_ms, a.round, a.worked), (61_510, 0, true));
        let a: ClockAck =
            crate::decode(br#"{"time_ms":61510,"round":2,"worked":false}"#, "ack").unwrap();
        assert_eq!((a.round, a.worked), (2, false));
        let c: Clock = crate::decode(br#"{"time_ms":61500,"lockstep":true}"#, "clock").unwrap();
        assert_eq!((c.time_ms, c.round, c.parties.len()), (61_500, 0, 0));
        let round = Clock {
            time_ms: 10,
            lockstep: true,
            round: 1,
            parties: vec!["a1".into()],
            release: false,
        };
        assert_eq!(
            String::from_utf8(crate::encode(&round)).unwrap(),
            r#"{"time_ms":10,"lockstep":true,"round":1,"parties":["a1"]}"#
        );
        let c: Clock = crate::decode(
            br#"{"time_ms":10,"lockstep":true,"round":2,"release":true}"#,
            "clock",
        )
        .unwrap();
        assert!(c.release && !a.holding);
        let a: ClockAck = crate::decode(br#"{"time_ms":10,"holding":true}"#, "ack").unwrap();
        assert!(a.holding && a.worked);
        let a = ContactCount {
            wall: 1,
            robot: 0,
            bumper: 1,
        };
        let b = ContactCount {
            wall: 3,
            robot: 1,
            bumper: 2,
        };
        assert_eq!(
            a.since(&b),
            ContactCount {
                wall: 2,
                robot: 1,
                bumper: 1
            }
        );
        assert_eq!(a.since(&b).total(), 3);
    }
}

//! The running example's modules: wander, avoid and escape, each a module
//! M(P, φ) of §4.8.2 over what a base's sensors say.
//!
//! Every module is asked once a control period; it answers `None` when its
//! applicability predicate P does not hold and otherwise the command φ
//! gives, which its client process sends to the base (again every period,
//! since a colony-style module's output is a stream, §3.2.2).

use std::fmt;

/// Sonars on the ring (index 12 looks straight ahead, 15° apart,
/// counter-clockwise: 18 looks left, 6 right).
pub const SONARS: usize = 24;
const AHEAD: usize = 12;
const LEFT: usize = 18;
const RIGHT: usize = 6;

/// What a module reads of the base.
#[derive(Debug, Clone, PartialEq)]
pub struct Senses {
    /// The last sonar scan, mm (ranges past the timeout read as the
    /// timeout).
    pub sonar: [u16; SONARS],
    /// Whether a bumper touches something.
    pub bumped: bool,
}

/// A command for the base: go at `velocity_mm_s` and, if `jog_deg_s` is
/// given, jog at that rate (Table 4.1's `go` then `jog`; a positive rate
/// turns clockwise, as the base's).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Forward speed, mm/s (negative backwards).
    pub velocity_mm_s: f64,
    /// Turn rate while going, °/s clockwise; `None` to go straight.
    pub jog_deg_s: Option<f64>,
}

impl fmt::Display for Command {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "go {:.0}", self.velocity_mm_s)?;
        if let Some(j) = self.jog_deg_s {
            write!(f, ", jog {j:.0}")?;
        }
        Ok(())
    }
}

/// Which behaviour a module is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kind {
    /// Always applicable: forward at cruise speed, turning at a rate drawn
    /// at random every [`WANDER_CHANGE_MS`] (±[`WANDER_JOG_DEG_S`]).
    Wander,
    /// Applicable while something is within [`AVOID_MM`] ahead: slow (in
    /// place within [`TURN_IN_PLACE_MM`]), and turn towards the side that
    /// had more room when it began, until the way ahead is clear.
    Avoid,
    /// Applicable from a bumper's touch for [`ESCAPE_MS`]: back off
    /// [`BACK_OFF_MS`], then turn in place towards the side that had more
    /// room at the touch.
    Escape,
}

impl Kind {
    /// The behaviours by name, as a network's modules are named.
    pub const ALL: [(&'static str, Kind); 3] = [
        ("wander", Kind::Wander),
        ("avoid", Kind::Avoid),
        ("escape", Kind::Escape),
    ];

    /// The behaviour a module name stands for.
    pub fn from_name(name: &str) -> Option<Kind> {
        Self::ALL.iter().find(|(n, _)| *n == name).map(|(_, k)| *k)
    }
}

/// Wander's speed, mm/s.
pub const CRUISE_MM_S: f64 = 350.0;
/// How often wander draws a new turn rate, ms.
pub const WANDER_CHANGE_MS: u64 = 3_000;
/// Wander's largest turn rate, °/s.
pub const WANDER_JOG_DEG_S: f64 = 20.0;
/// Avoid's trigger: the nearest of the seven sonars ahead (±45°), mm.
pub const AVOID_MM: u16 = 800;
/// Nearer than this ahead, avoid turns in place, mm.
pub const TURN_IN_PLACE_MM: u16 = 500;
/// How long escape stays applicable after a touch, ms.
pub const ESCAPE_MS: u64 = 2_500;
/// How long of that escape backs off, ms.
pub const BACK_OFF_MS: u64 = 1_000;

/// A module with its state: the side an avoid or escape turns to, kept
/// for the whole episode so that a corner, with room alike on both
/// sides, does not make it dither; escape's last touch; wander's turn
/// rate and its random draws.
#[derive(Debug, Clone)]
pub struct Module {
    kind: Kind,
    touched_at: Option<u64>,
    side: Option<f64>,
    rate: f64,
    next_draw: u64,
    rng: u64,
}

impl Module {
    /// A module of this kind, nothing remembered; `seed` drives wander's
    /// draws.
    pub fn new(kind: Kind, seed: u64) -> Self {
        Module {
            kind,
            touched_at: None,
            side: None,
            rate: 0.0,
            next_draw: 0,
            rng: seed ^ 0x9E37_79B9_7F4A_7C15,
        }
    }

    /// A uniform draw in [0, 1) (SplitMix64).
    fn uniform(&mut self) -> f64 {
        self.rng = self.rng.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.rng;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^= z >> 31;
        (z >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Its behaviour.
    pub fn kind(&self) -> Kind {
        self.kind
    }

    /// P and φ at `now_ms`: the command to send, or `None` when the
    /// module's predicate does not hold.
    pub fn decide(&mut self, s: &Senses, now_ms: u64) -> Option<Command> {
        // Positive: more room on the right, where a positive (clockwise)
        // rate turns.
        let room = f64::from(s.sonar[RIGHT]) - f64::from(s.sonar[LEFT]);
        let roomier = if room >= 0.0 { 1.0 } else { -1.0 };
        match self.kind {
            Kind::Wander => {
                if now_ms >= self.next_draw {
                    self.rate = (2.0 * self.uniform() - 1.0) * WANDER_JOG_DEG_S;
                    self.next_draw = now_ms + WANDER_CHANGE_MS;
                }
                Some(Command {
                    velocity_mm_s: CRUISE_MM_S,
                    jog_deg_s: Some(self.rate),
                })
            }
            Kind::Avoid => {
                let ahead = s.sonar[AHEAD - 3..=AHEAD + 3].iter().copied().min()?;
                if ahead >= AVOID_MM {
                    self.side = None;
                    return None;
                }
                let side = *self.side.get_or_insert(roomier);
                Some(Command {
                    velocity_mm_s: if ahead < TURN_IN_PLACE_MM { 0.0 } else { 100.0 },
                    jog_deg_s: Some(45.0 * side),
                })
            }
            Kind::Escape => {
                if s.bumped {
                    if self.touched_at.is_none() {
                        self.side = Some(roomier);
                    }
                    self.touched_at = Some(now_ms);
                }
                let since = now_ms.saturating_sub(self.touched_at?);
                if since >= ESCAPE_MS {
                    self.touched_at = None;
                    self.side = None;
                    return None;
                }
                Some(if since < BACK_OFF_MS {
                    Command {
                        velocity_mm_s: -250.0,
                        jog_deg_s: None,
                    }
                } else {
                    Command {
                        velocity_mm_s: 0.0,
                        jog_deg_s: Some(60.0 * self.side.unwrap_or(roomier)),
                    }
                })
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn senses(ahead: u16, left: u16, right: u16, bumped: bool) -> Senses {
        let mut sonar = [5_000; SONARS];
        sonar[AHEAD] = ahead;
        sonar[LEFT] = left;
        sonar[RIGHT] = right;
        Senses { sonar, bumped }
    }

    #[test]
    fn wander_always_applies_and_draws_a_new_turn_now_and_then() {
        let mut m = Module::new(Kind::Wander, 7);
        let mut rates = Vec::new();
        for t in (0..30_000).step_by(100) {
            let c = m.decide(&senses(300, 500, 4_000, t % 2 == 0), t).unwrap();
            assert_eq!(c.velocity_mm_s, CRUISE_MM_S);
            let r = c.jog_deg_s.unwrap();
            assert!(r.abs() <= WANDER_JOG_DEG_S);
            if rates.last() != Some(&r) {
                rates.push(r);
            }
        }
        assert_eq!(rates.len() as u64, 30_000 / WANDER_CHANGE_MS, "{rates:?}");
        let again: Vec<f64> = {
            let mut m = Module::new(Kind::Wander, 7);
            (0..10)
                .map(|k| {
                    m.decide(&senses(5_000, 1, 1, false), k * WANDER_CHANGE_MS)
                        .unwrap()
                        .jog_deg_s
                        .unwrap()
                })
                .collect()
        };
        assert_eq!(again, rates, "the same seed, the same draws");
    }

    #[test]
    fn avoid_applies_only_with_something_close_ahead() {
        let mut m = Module::new(Kind::Avoid, 1);
        assert_eq!(m.decide(&senses(AVOID_MM, 1_000, 2_000, false), 0), None);
        let c = m
            .decide(&senses(AVOID_MM - 1, 1_000, 2_000, false), 0)
            .unwrap();
        assert_eq!(c.jog_deg_s, Some(45.0), "more room on the right: clockwise");
        assert!(c.velocity_mm_s > 0.0 && c.velocity_mm_s < CRUISE_MM_S);
        // In a corner the sides change places; the turn keeps its side.
        let c = m
            .decide(&senses(TURN_IN_PLACE_MM - 1, 2_000, 1_000, false), 100)
            .unwrap();
        assert_eq!((c.velocity_mm_s, c.jog_deg_s), (0.0, Some(45.0)));
        // Clear ahead: the episode ends, and the next one picks afresh.
        assert_eq!(m.decide(&senses(AVOID_MM, 2_000, 1_000, false), 200), None);
        let c = m
            .decide(&senses(AVOID_MM - 1, 2_000, 1_000, false), 300)
            .unwrap();
        assert_eq!(c.jog_deg_s, Some(-45.0));
    }

    #[test]
    fn escape_backs_off_then_turns_then_lets_go() {
        let mut m = Module::new(Kind::Escape, 1);
        let free = senses(5_000, 3_000, 1_000, false);
        assert_eq!(m.decide(&free, 0), None, "no touch yet");
        let back = m.decide(&senses(100, 3_000, 1_000, true), 10_000).unwrap();
        assert!(back.velocity_mm_s < 0.0 && back.jog_deg_s.is_none());
        // The touch is over, the stream goes on: still backing off.
        assert_eq!(m.decide(&free, 10_000 + BACK_OFF_MS - 1), Some(back));
        let turn = m.decide(&free, 10_000 + BACK_OFF_MS).unwrap();
        assert_eq!((turn.velocity_mm_s, turn.jog_deg_s), (0.0, Some(-60.0)));
        assert_eq!(m.decide(&free, 10_000 + ESCAPE_MS), None);
        assert_eq!(m.decide(&free, 10_000 + ESCAPE_MS + 1), None);
        // A new touch while escaping starts over.
        m.decide(&senses(100, 1_000, 3_000, true), 20_000).unwrap();
        let again = m.decide(&senses(100, 1_000, 3_000, true), 20_000 + 1_500);
        assert!(again.unwrap().velocity_mm_s < 0.0);
    }

    #[test]
    fn module_names_are_the_networks() {
        for (name, kind) in Kind::ALL {
            assert_eq!(Kind::from_name(name), Some(kind));
        }
        assert_eq!(Kind::from_name("hide"), None);
    }
}

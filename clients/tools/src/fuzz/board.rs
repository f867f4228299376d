//! Blackboard cases: a wrong-typed or out-of-range value on one of a
//! robot's navigation variables (`nav/<robot>/…`), as any client on the
//! network may write one, and often the up() that sets a navigation client
//! reading it. The clients must end the work at hand with the reason and
//! go on, never exit: `--pid` of each client checks that.

use crate::fuzz::garbage::pick;
use rome_client::DataClient;
use rome_nav::board::{Board, Sem, Var};
use rome_sim::rng::Rng;

/// Each variable a navigation client reads, with the semaphore whose up()
/// has a client read it at once (`None`: read while a goal is carried out,
/// or at a client's start).
const READS: &[(Var, Option<Sem>)] = &[
    (Var::GoalType, Some(Sem::GoalData)),
    (Var::GoalDistance, Some(Sem::GoalData)),
    (Var::GoalDirection, Some(Sem::GoalData)),
    (Var::LightOffset, Some(Sem::TrackData)),
    (Var::GoalDistance, Some(Sem::TrackData)),
    (Var::GoalDirection, Some(Sem::TrackData)),
    (Var::GoalDirection, Some(Sem::StartMap)),
    (Var::GoalDistance, Some(Sem::StartMap)),
    (Var::Corridor, Some(Sem::StartMap)),
    (Var::CeilingLight, Some(Sem::LightDet)),
    (Var::GoalActive, None),
    (Var::EndWall, None),
    (Var::GoalLane, None),
    (Var::GoalWalls, None),
    (Var::Glass, None),
    (Var::Overshoot, None),
    (Var::CountedAt, None),
    (Var::TrackLog, None),
    (Var::Status, None),
    (Var::Traffic, None),
];

/// Values of the wrong type, or out of any sensible range.
const BAD: &[&str] = &[
    "\"many\"",
    "{\"lights\":\"many\"}",
    "[1,[2]]",
    "-1",
    "-9223372036854775808",
    "18446744073709551615",
    "1e308",
    "-1e308",
    "null",
    "true",
    "\"\"",
    "[]",
    "{}",
    "[1e308,-1e308,0]",
];

/// One blackboard case.
#[derive(Debug, Clone)]
pub struct BoardCase {
    robot: String,
    var: Var,
    value: &'static str,
    signal: Option<Sem>,
}

impl BoardCase {
    /// A case on `robot`'s blackboard.
    pub fn generate(rng: &mut Rng, robot: &str) -> BoardCase {
        let (var, sem) = READS[pick(rng, READS.len())];
        BoardCase {
            robot: robot.to_string(),
            var,
            value: BAD[pick(rng, BAD.len())],
            // Mostly with the up(): a value nobody reads tests nothing.
            signal: sem.filter(|_| pick(rng, 4) != 0),
        }
    }

    /// What the case writes, for the summary.
    pub fn describe(&self) -> String {
        let then = match self.signal {
            Some(s) => format!(", then up(${})", s.name()),
            None => String::new(),
        };
        format!(
            "nav/{}/{} = {}{then}",
            self.robot,
            self.var.name(),
            self.value
        )
    }

    /// Writes the value (and signals), through the data server as any
    /// client would: `Err` with the server's reason if it refused.
    pub async fn send(&self, ds: &DataClient) -> Result<(), String> {
        let board = Board::new(ds.clone(), &self.robot);
        let value: serde_json::Value =
            serde_json::from_str(self.value).map_err(|e| e.to_string())?;
        board
            .set(self.var, &value)
            .await
            .map_err(|e| e.to_string())?;
        if let Some(sem) = self.signal {
            board.up(sem).await.map_err(|e| e.to_string())?;
        }
        Ok(())
    }
}

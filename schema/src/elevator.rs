//! The elevator server's messages: an elevator is a device with a server
//! of its own (§5.4.6, where a human operator pressed the buttons; here a
//! robot may too), under `<root>/building/elevator/<name>/…`.
//!
//! ```text
//! get rome/building/elevator/acs.elev/call   payload {"floor":"3"}  -> {"command":"call","state":{…}}
//! get rome/building/elevator/acs.elev/go     payload {"floor":"5"}  -> {"command":"go","state":{…}}
//! get rome/building/elevator/acs.elev/open                          -> {"command":"open","state":{…}}
//! get rome/building/elevator/acs.elev/close                         -> {"command":"close","state":{…}}
//! get rome/building/elevator/acs.elev/state                         -> {"elevator":"acs.elev","floor":"3",…}
//! get rome/building/elevator/acs.elev/lock?owner=c7-r1;ttl_ms=2500  -> the session, as a base's lock
//! sub rome/building/elevator/acs.elev/state                         <- the state, at a fixed rate
//! put rome/building/elevator/acs.elev/press  payload {"floor":"5"}  -> a button pressed, by anyone
//! ```
//!
//! The commands take the session the way a base's commands take its lock
//! (`lock`, `unlock`, the fence, liveliness; [`crate::robot::command`]).
//! While a client holds it, the others' commands wait. A button is not a
//! command: it is wired to the car, so a press is a plain put that the
//! car takes whoever holds the session, as a person in the hall would
//! press it.

use crate::robot::command::{Command, Payload};
use crate::robot::LockInfo;
use crate::{ErrorCode, ErrorReply};
use serde::{Deserialize, Serialize};

/// `call`: the car is wanted at a floor (a hall call); it comes, and its
/// doors open there.
///
/// ```text
/// {"floor":"3"}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Call {
    /// The floor's name, as the building names it.
    pub floor: String,
}

/// `go`: the car is to go to a floor (a car call); it closes its doors,
/// travels, and opens them there.
///
/// ```text
/// {"floor":"5"}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GoTo {
    /// The floor's name.
    pub floor: String,
}

/// `open`: opens the doors at the floor where the car stands and holds
/// them open until `close`, `go` or the end of the session.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Open;

/// `close`: closes the doors (the car then serves its next stop).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Close;

/// `state`: reads the car's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct ReadState;

/// A button pressed (inside the car or in a hall): a put on `press`.
///
/// ```text
/// {"floor":"5"}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Press {
    /// The floor whose button was pressed.
    pub floor: String,
}

/// The doors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Doors {
    /// Shut: the car may move.
    Closed,
    /// Opening.
    Opening,
    /// Open.
    Open,
    /// Closing.
    Closing,
}

/// The car's state, published on `state` and answered to every command.
///
/// ```text
/// {"elevator":"acs.elev","floors":["3","4","5"],"floor":"4","position":1.0,
///  "moving":false,"doors":"open","held":false,"stops":[],"lock":null}
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElevatorState {
    /// The elevator's name.
    pub elevator: String,
    /// The floors it serves, lowest first.
    pub floors: Vec<String>,
    /// The floor the car is at, or last passed.
    pub floor: String,
    /// Where the car is: the index of `floors`, fractional between two.
    pub position: f64,
    /// Whether the car travels.
    pub moving: bool,
    /// The doors.
    pub doors: Doors,
    /// Whether the doors are held open (`open`) rather than open for a
    /// while at a stop.
    pub held: bool,
    /// Floors the car will stop at, in order.
    pub stops: Vec<String>,
    /// Who holds the session, if anyone.
    pub lock: Option<LockInfo>,
}

/// What a command answers: its name and the state it left.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ElevatorDone {
    /// The command carried out.
    pub command: String,
    /// The car's state afterwards.
    pub state: ElevatorState,
}

/// Refuses a floor name that is empty or not printable.
fn check_floor(command: &str, floor: &str) -> Result<(), ErrorReply> {
    if floor.is_empty() || floor.len() > 64 || floor.chars().any(char::is_control) {
        return Err(ErrorReply::new(
            ErrorCode::OutOfRange,
            format!("'{command}': the floor must be a name of 1 to 64 printable characters"),
        ));
    }
    Ok(())
}

impl Command for Call {
    const NAME: &'static str = "call";
    const ACTS: bool = true;
    type Reply = ElevatorDone;
    fn payload(&self) -> Option<Vec<u8>> {
        Some(crate::encode(self))
    }
}

impl Payload for Call {
    const EXAMPLE: &'static str = r#"{"floor":"3"}"#;
    fn check(&self) -> Result<(), ErrorReply> {
        check_floor(Self::NAME, &self.floor)
    }
}

impl Command for GoTo {
    const NAME: &'static str = "go";
    const ACTS: bool = true;
    type Reply = ElevatorDone;
    fn payload(&self) -> Option<Vec<u8>> {
        Some(crate::encode(self))
    }
}

impl Payload for GoTo {
    const EXAMPLE: &'static str = r#"{"floor":"5"}"#;
    fn check(&self) -> Result<(), ErrorReply> {
        check_floor(Self::NAME, &self.floor)
    }
}

impl Command for Open {
    const NAME: &'static str = "open";
    const ACTS: bool = true;
    type Reply = ElevatorDone;
}

impl Command for Close {
    const NAME: &'static str = "close";
    const ACTS: bool = true;
    type Reply = ElevatorDone;
}

impl Command for ReadState {
    const NAME: &'static str = "state";
    const ACTS: bool = false;
    type Reply = ElevatorState;
}

impl Press {
    /// Refuses a press naming no floor.
    pub fn check(&self) -> Result<(), ErrorReply> {
        check_floor("press", &self.floor)
    }
}

impl crate::Root {
    /// `<root>/building/elevator/<name>/<chunk>`.
    pub fn elevator(&self, name: &crate::Name, chunk: &str) -> String {
        format!("{}/building/elevator/{name}/{chunk}", self.as_str())
    }
}

/// The commands, for errors and docs (`lock` and `unlock` besides).
pub const COMMANDS: &[&str] = &[
    Call::NAME,
    GoTo::NAME,
    Open::NAME,
    Close::NAME,
    ReadState::NAME,
];

/// The key chunk of a button press.
pub const PRESS: &str = "press";

#[cfg(test)]
mod tests {
    use super::*;
    use crate::robot::command::parse_payload;

    #[test]
    fn a_call_parses_strictly_and_names_what_is_wrong() {
        let c: Call = parse_payload(Some(br#"{"floor":"3"}"#)).unwrap();
        assert_eq!(c.floor, "3");
        let e = parse_payload::<GoTo>(Some(br#"{"floor":3}"#)).unwrap_err();
        assert_eq!(e.code, ErrorCode::WrongType);
        assert!(e.message.contains(r#"{"floor":"5"}"#), "{}", e.message);
        let e = parse_payload::<Call>(Some(br#"{"floor":""}"#)).unwrap_err();
        assert_eq!(e.code, ErrorCode::OutOfRange);
        let e = parse_payload::<Call>(Some(br#"{"floor":"3","car":1}"#)).unwrap_err();
        assert!(e.message.contains("car"), "{}", e.message);
    }

    #[test]
    fn the_state_reads_back_as_written() {
        let s = ElevatorState {
            elevator: "acs.elev".into(),
            floors: vec!["3".into(), "4".into(), "5".into()],
            floor: "4".into(),
            position: 1.0,
            moving: false,
            doors: Doors::Open,
            held: true,
            stops: vec!["5".into()],
            lock: None,
        };
        let back: ElevatorState = crate::decode(&crate::encode(&s), "state").unwrap();
        assert_eq!(back, s);
        assert!(String::from_utf8(crate::encode(&s))
            .unwrap()
            .contains(r#""doors":"open""#));
    }
}

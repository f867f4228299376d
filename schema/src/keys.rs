//! The key-expression scheme: one builder and one parser for every key.
//!
//! Everything lives under a root prefix (default `rome`) so two deployments
//! can share a router. The data server's keys all have the form
//! `<root>/data/<op>/<name>`, with the operation *before* the name: names may
//! span several chunks (`r1/Pose`), and Zenoh access control can then allow
//! or deny each operation by key alone.
//!
//! ```text
//! rome/data/var/PosX          the variable PosX (put, delete, get ?back=N)
//! rome/data/set/PosX          acknowledged write (query with a JSON payload)
//! rome/data/history/PosX      history length (query, ?len=N sets it)
//! rome/data/watch/PosX        committed writes, published by the server
//! rome/data/sem/GoalData      semaphore state (query)
//! rome/data/create/GoalData   create a semaphore (?value=N)
//! rome/data/signal/GoalData   up()
//! rome/data/wait/GoalData     blocking down()
//! rome/data/try-wait/GoalData non-blocking down()
//! rome/data/cancel/GoalData   give up a queued wait
//! rome/data/ack/GoalData      confirm a granted wait
//! rome/alive/...              liveliness tokens (`rome ls`)
//! ```

use std::fmt;

/// The default root prefix.
pub const DEFAULT_ROOT: &str = "rome";

/// The longest name accepted, in bytes; keeps keys and logs readable.
pub const MAX_NAME_LEN: usize = 200;

/// A key or name that does not follow the scheme.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum KeyError {
    /// A variable, semaphore or other name is not valid.
    #[error("invalid name '{name}': {why}")]
    BadName {
        /// The offending name.
        name: String,
        /// What rule it breaks.
        why: String,
    },
    /// The key is not under this deployment's root.
    #[error("key '{key}' is not under the root '{root}'")]
    OutsideRoot {
        /// The key.
        key: String,
        /// The root prefix in use.
        root: String,
    },
    /// The key is under the root but names no known operation.
    #[error("key '{key}' names no data-server operation; expected <root>/data/<op>/<name> with op one of {ops}")]
    UnknownOp {
        /// The key.
        key: String,
        /// The operations there are.
        ops: String,
    },
}

/// Checks one chunk-separated path (a name or a root) against the scheme.
///
/// Allowed: chunks of ASCII letters, digits, `_`, `-` and `.`, separated by
/// single `/`. That keeps every name a literal Zenoh key (no wildcards, no
/// `$`, no verbatim `@` chunks) and safe in a URL for the REST plugin.
fn check_path(name: &str) -> Result<(), String> {
    if name.is_empty() {
        return Err("it is empty".into());
    }
    if name.len() > MAX_NAME_LEN {
        return Err(format!(
            "it is {} bytes long; at most {MAX_NAME_LEN}",
            name.len()
        ));
    }
    for chunk in name.split('/') {
        if chunk.is_empty() {
            return Err("it has an empty chunk (leading, trailing or double '/')".into());
        }
        if let Some(c) = chunk
            .chars()
            .find(|c| !(c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.')))
        {
            return Err(format!(
                "character '{c}' is not allowed; use letters, digits, '_', '-', '.' and '/' between chunks"
            ));
        }
    }
    Ok(())
}

/// A valid name of a variable, semaphore, robot or client: a literal key path.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct Name(String);

impl Name {
    /// Validates a name.
    pub fn new(name: impl Into<String>) -> Result<Self, KeyError> {
        let name = name.into();
        match check_path(&name) {
            Ok(()) => Ok(Name(name)),
            Err(why) => Err(KeyError::BadName { name, why }),
        }
    }

    /// A semaphore name in the thesis' spelling: `$GoalData` is `GoalData`.
    ///
    /// `$` is not allowed in a Zenoh key chunk, and the key already says
    /// "semaphore", so the one leading `$` is dropped; a name without it is
    /// taken as it is.
    pub fn semaphore(name: &str) -> Result<Self, KeyError> {
        Name::new(name.strip_prefix('$').unwrap_or(name))
    }

    /// The name as text.
    pub fn as_str(&self) -> &str {
        &self.0
    }
}

impl fmt::Display for Name {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.0)
    }
}

impl AsRef<str> for Name {
    fn as_ref(&self) -> &str {
        &self.0
    }
}

/// The operations of the data server, as they appear in its keys.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum DataOp {
    /// `var`: the variable itself.
    Var,
    /// `set`: acknowledged write.
    Set,
    /// `history`: read or set the history length.
    History,
    /// `watch`: committed writes (publications).
    Watch,
    /// `sem`: semaphore state.
    Sem,
    /// `create`: create a semaphore.
    Create,
    /// `signal`: up().
    Signal,
    /// `wait`: blocking down().
    Wait,
    /// `try-wait`: non-blocking down().
    TryWait,
    /// `cancel`: give up a queued wait.
    Cancel,
    /// `ack`: confirm a granted wait.
    Ack,
}

impl DataOp {
    /// Every operation, in documentation order.
    pub const ALL: [DataOp; 11] = [
        DataOp::Var,
        DataOp::Set,
        DataOp::History,
        DataOp::Watch,
        DataOp::Sem,
        DataOp::Create,
        DataOp::Signal,
        DataOp::Wait,
        DataOp::TryWait,
        DataOp::Cancel,
        DataOp::Ack,
    ];

    /// The key chunk of this operation.
    pub fn chunk(self) -> &'static str {
        match self {
            DataOp::Var => "var",
            DataOp::Set => "set",
            DataOp::History => "history",
            DataOp::Watch => "watch",
            DataOp::Sem => "sem",
            DataOp::Create => "create",
            DataOp::Signal => "signal",
            DataOp::Wait => "wait",
            DataOp::TryWait => "try-wait",
            DataOp::Cancel => "cancel",
            DataOp::Ack => "ack",
        }
    }

    fn from_chunk(chunk: &str) -> Option<Self> {
        DataOp::ALL.into_iter().find(|op| op.chunk() == chunk)
    }

    /// Whether a request of this operation changes nothing. In a run split
    /// into processes the data server answers these within their round and
    /// holds anything else until its round is over (`history`, which may
    /// set a length, among them).
    pub fn only_reads(self) -> bool {
        matches!(self, DataOp::Var | DataOp::Sem | DataOp::Watch)
    }
}

/// A parsed data-server key: an operation on a name.
#[derive(Debug, Clone, PartialEq, Eq, Hash)]
pub struct DataKey {
    /// The operation.
    pub op: DataOp,
    /// The variable or semaphore it applies to.
    pub name: Name,
}

/// A deployment's root prefix, and the builders of every key under it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Root(String);

impl Default for Root {
    fn default() -> Self {
        Root(DEFAULT_ROOT.to_string())
    }
}

impl Root {
    /// Validates a root prefix (`rome`, `lab2/rome` …).
    pub fn new(root: impl Into<String>) -> Result<Self, KeyError> {
        let root = root.into();
        match check_path(&root) {
            Ok(()) => Ok(Root(root)),
            Err(why) => Err(KeyError::BadName { name: root, why }),
        }
    }

    /// The prefix as text.
    pub fn as_str(&self) -> &str {
        &self.0
    }

    /// `<root>/data/<op>/<name>`.
    pub fn data(&self, op: DataOp, name: &Name) -> String {
        format!("{}/data/{}/{}", self.0, op.chunk(), name)
    }

    /// `<root>/data/<op>/**`: every key of one operation.
    pub fn data_all_of(&self, op: DataOp) -> String {
        format!("{}/data/{}/**", self.0, op.chunk())
    }

    /// `<root>/data/<op>/<pattern>`: the keys of one operation whose names
    /// a pattern matches (`fleet/task/*`, `nav/*/Duty`).
    pub fn data_matching(&self, op: DataOp, pattern: &str) -> String {
        format!("{}/data/{}/{}", self.0, op.chunk(), pattern)
    }

    /// `<root>/data/**`: everything the data server answers.
    pub fn data_all(&self) -> String {
        format!("{}/data/**", self.0)
    }

    /// `<root>/data/rejected`: where the server reports puts it refused
    /// (a put has no reply to carry the error).
    pub fn rejected(&self) -> String {
        format!("{}/data/rejected", self.0)
    }

    /// `<root>/data/<op>/<pattern>` for a name pattern that may hold the
    /// Zenoh wildcards `*` and `**` as whole chunks (`Goal*` is not one).
    pub fn data_pattern(&self, op: DataOp, pattern: &str) -> Result<String, KeyError> {
        let bad = |why: &str| KeyError::BadName {
            name: pattern.to_string(),
            why: why.to_string(),
        };
        if pattern.is_empty() {
            return Err(bad("the pattern is empty"));
        }
        for chunk in pattern.split('/') {
            if chunk == "*" || chunk == "**" {
                continue;
            }
            check_path(chunk).map_err(|why| bad(&why))?;
        }
        Ok(format!("{}/data/{}/{}", self.0, op.chunk(), pattern))
    }

    /// Parses a data-server key (without selector parameters).
    pub fn parse_data(&self, key: &str) -> Result<DataKey, KeyError> {
        let outside = || KeyError::OutsideRoot {
            key: key.to_string(),
            root: self.0.clone(),
        };
        let rest = key
            .strip_prefix(self.0.as_str())
            .and_then(|r| r.strip_prefix("/data/"))
            .ok_or_else(outside)?;
        let unknown = || KeyError::UnknownOp {
            key: key.to_string(),
            ops: DataOp::ALL.map(|o| o.chunk()).join(", "),
        };
        let (op, name) = rest.split_once('/').ok_or_else(unknown)?;
        let op = DataOp::from_chunk(op).ok_or_else(unknown)?;
        Ok(DataKey {
            op,
            name: Name::new(name)?,
        })
    }

    /// `<root>/alive/server/<kind>/<id>`: a server's liveliness token.
    pub fn alive_server(&self, kind: &str, id: &str) -> String {
        format!("{}/alive/server/{kind}/{id}", self.0)
    }

    /// `<root>/alive/client/<role>/<owner>`: a client's liveliness token.
    ///
    /// The last chunk is the client's owner id, which it also sends with
    /// semaphore waits, so the data server can drop a crashed client's place.
    pub fn alive_client(&self, role: &str, owner: &str) -> String {
        format!("{}/alive/client/{role}/{owner}", self.0)
    }

    /// `<root>/alive/**`: every liveliness token of this deployment.
    pub fn alive_all(&self) -> String {
        format!("{}/alive/**", self.0)
    }

    /// `<root>/alive/client/**`: every client's liveliness token.
    pub fn alive_clients(&self) -> String {
        format!("{}/alive/client/**", self.0)
    }

    /// Parses a liveliness key into (kind path, id): the id is the last chunk.
    pub fn parse_alive<'k>(&self, key: &'k str) -> Option<Alive<'k>> {
        let rest = key.strip_prefix(self.0.as_str())?.strip_prefix("/alive/")?;
        let (kind, id) = rest.rsplit_once('/')?;
        let (class, role) = kind.split_once('/')?;
        let class = match class {
            "server" => AliveClass::Server,
            "client" => AliveClass::Client,
            _ => return None,
        };
        Some(Alive { class, role, id })
    }
}

/// Whether a live participant is a server or a client.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AliveClass {
    /// A data or hardware server.
    Server,
    /// A client (CLI, navigation client, tool).
    Client,
}

/// A parsed liveliness key.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Alive<'k> {
    /// Server or client.
    pub class: AliveClass,
    /// What it is (`data`, `cli`, `planner` …).
    pub role: &'k str,
    /// Its unique id (for clients, the semaphore owner id).
    pub id: &'k str,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reads_are_the_ops_that_change_nothing() {
        let reads: Vec<DataOp> = DataOp::ALL
            .into_iter()
            .filter(|op| op.only_reads())
            .collect();
        // `history?len=5` sets the length: a change.
        assert_eq!(reads, [DataOp::Var, DataOp::Watch, DataOp::Sem]);
    }

    #[test]
    fn every_op_round_trips() {
        let root = Root::default();
        for name in ["PosX", "r1/Pose", "a.b-c_d", "x/y/z"] {
            let name = Name::new(name).unwrap();
            for op in DataOp::ALL {
                let key = root.data(op, &name);
                let parsed = root.parse_data(&key).unwrap();
                assert_eq!(
                    parsed,
                    DataKey {
                        op,
                        name: name.clone()
                    },
                    "{key}"
                );
            }
        }
    }

    #[test]
    fn custom_root_round_trips_and_is_kept_apart() {
        let lab = Root::new("lab2/rome").unwrap();
        let name = Name::new("GoalType").unwrap();
        let key = lab.data(DataOp::Var, &name);
        assert_eq!(key, "lab2/rome/data/var/GoalType");
        assert_eq!(lab.parse_data(&key).unwrap().name, name);
        assert!(matches!(
            Root::default().parse_data(&key),
            Err(KeyError::OutsideRoot { .. })
        ));
    }

    #[test]
    fn thesis_semaphore_names_drop_the_dollar() {
        assert_eq!(Name::semaphore("$GoalData").unwrap().as_str(), "GoalData");
        assert_eq!(Name::semaphore("GoalData").unwrap().as_str(), "GoalData");
        assert!(Name::semaphore("$$x").is_err());
    }

    #[test]
    fn bad_names_say_why() {
        for (name, why) in [
            ("", "empty"),
            ("a//b", "empty chunk"),
            ("/a", "empty chunk"),
            ("a/", "empty chunk"),
            ("a*", "'*'"),
            ("$x", "'$'"),
            ("@x", "'@'"),
            ("a b", "' '"),
            ("a?b", "'?'"),
        ] {
            let err = Name::new(name).unwrap_err().to_string();
            assert!(err.contains(why), "{name:?}: {err}");
        }
        let long = "x".repeat(MAX_NAME_LEN + 1);
        assert!(Name::new(long).unwrap_err().to_string().contains("at most"));
    }

    #[test]
    fn unknown_ops_and_missing_names_are_refused() {
        let root = Root::default();
        let err = root.parse_data("rome/data/frobnicate/x").unwrap_err();
        assert!(matches!(err, KeyError::UnknownOp { .. }));
        assert!(err.to_string().contains("try-wait"));
        assert!(matches!(
            root.parse_data("rome/data/var").unwrap_err(),
            KeyError::UnknownOp { .. }
        ));
        assert!(matches!(
            root.parse_data("romex/data/var/a").unwrap_err(),
            KeyError::OutsideRoot { .. }
        ));
    }

    #[test]
    fn patterns_allow_whole_chunk_wildcards_only() {
        let root = Root::default();
        assert_eq!(
            root.data_pattern(DataOp::Watch, "r1/**").unwrap(),
            "rome/data/watch/r1/**"
        );
        assert_eq!(
            root.data_pattern(DataOp::Watch, "*/Pose").unwrap(),
            "rome/data/watch/*/Pose"
        );
        assert!(root.data_pattern(DataOp::Watch, "Goal*").is_err());
        assert!(root.data_pattern(DataOp::Watch, "").is_err());
    }

    #[test]
    fn alive_keys_round_trip() {
        let root = Root::default();
        let key = root.alive_client("planner", "0a1b-3");
        let alive = root.parse_alive(&key).unwrap();
        assert_eq!(alive.class, AliveClass::Client);
        assert_eq!(alive.role, "planner");
        assert_eq!(alive.id, "0a1b-3");
        let key = root.alive_server("data", "ff00");
        let alive = root.parse_alive(&key).unwrap();
        assert_eq!(
            (alive.class, alive.role, alive.id),
            (AliveClass::Server, "data", "ff00")
        );
        assert!(root.parse_alive("rome/alive/robot/x").is_none());
        assert!(root.parse_alive("other/alive/client/a/b").is_none());
    }
}

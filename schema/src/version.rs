//! Which build a program is and which protocol it speaks, so that hosts on
//! different builds find out, and say so, instead of refusing each other's
//! requests with a puzzling "has no parameter".
//!
//! Every program says it in two places:
//! - **On its liveliness token.** Beside each token (`<root>/alive/...`)
//!   the program declares a queryable on the same key that answers with
//!   [`Speaks`] as JSON. `rome ls` shows it; a client asks it when a
//!   server refuses a request it should have understood.
//! - **In every request and reply.** A client's query and a server's
//!   reply carry [`Speaks::to_tag`] in their attachment, after the
//!   lock-step stamp when there is one:
//!
//! ```text
//! attachment = [stamp: 32 bytes, "RMS1"…]? [tag]?
//! tag        = "RMV1" protocol:u32 little-endian  version: UTF-8 (the rest)
//! presence   = {"version":"0.1.0","protocol":1}
//! ```
//!
//! A server refuses a request whose tag names another protocol with
//! [`crate::ErrorCode::Version`]; builds from before protocol versions
//! send no tag and answer no presence query, and are named so.

use serde::{Deserialize, Serialize};
use std::fmt;

/// The wire protocol's number: raised whenever a request, reply, key or
/// stream message changes so that an older build would misread it.
pub const PROTOCOL: u32 = 1;

/// This build's version (the workspace's).
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The first bytes of a version tag.
const MAGIC: [u8; 4] = *b"RMV1";

/// A build and the protocol it speaks.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Speaks {
    /// The build's version, `0.1.0`.
    pub version: String,
    /// Its protocol number ([`PROTOCOL`] of that build).
    pub protocol: u32,
}

impl Speaks {
    /// This build.
    pub fn this() -> Speaks {
        Speaks {
            version: VERSION.to_string(),
            protocol: PROTOCOL,
        }
    }

    /// The tag as carried at the end of an attachment.
    pub fn to_tag(&self) -> Vec<u8> {
        let mut b = Vec::with_capacity(8 + self.version.len());
        b.extend_from_slice(&MAGIC);
        b.extend_from_slice(&self.protocol.to_le_bytes());
        b.extend_from_slice(self.version.as_bytes());
        b
    }

    /// A tag from its bytes; `None` unless they are one (anyone may attach
    /// anything, so a short or foreign attachment is simply no tag).
    pub fn from_tag(b: &[u8]) -> Option<Speaks> {
        if b.len() < 8 || b[..4] != MAGIC {
            return None;
        }
        let mut p = [0u8; 4];
        p.copy_from_slice(&b[4..8]);
        let version = std::str::from_utf8(&b[8..]).ok()?;
        if version.is_empty() || version.len() > 64 {
            return None;
        }
        Some(Speaks {
            version: version.to_string(),
            protocol: u32::from_le_bytes(p),
        })
    }

    /// What to do about `other` speaking another protocol than `self`:
    /// the side with the lower protocol is the one to upgrade.
    pub fn upgrade_advice(&self, me: &str, other: &Speaks, them: &str) -> String {
        if other.protocol < self.protocol {
            format!("upgrade {them} to rome {} or later", self.version)
        } else {
            format!("upgrade {me} to rome {} or later", other.version)
        }
    }
}

impl fmt::Display for Speaks {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "rome {} (protocol {})", self.version, self.protocol)
    }
}

/// How a peer that says nothing of its version is named: a build from
/// before protocol versions, or not a RoME program at all.
pub const UNSAID: &str = "a build older than protocol versions (it did not say its version)";

/// The sentence for a client and a server that speak different
/// protocols, naming both and which to upgrade. `server` is who answered
/// (`the data server`, `r1/base`); `None` for one that said nothing.
pub fn differ(client: &Speaks, server_name: &str, server: Option<&Speaks>) -> String {
    match server {
        Some(s) => format!(
            "versions differ: this client is {client}, {server_name} is {s}; {}",
            client.upgrade_advice("this client", s, server_name)
        ),
        None => format!(
            "versions differ: this client is {client}, {server_name} is {UNSAID}; upgrade {server_name} to rome {} or later",
            client.version
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tag_round_trips_and_foreign_bytes_are_no_tag() {
        let s = Speaks::this();
        assert_eq!(Speaks::from_tag(&s.to_tag()), Some(s.clone()));
        assert_eq!(Speaks::from_tag(b"RMV1"), None);
        assert_eq!(Speaks::from_tag(b"RMS1\x01\0\0\x000.1.0"), None);
        let mut bad = s.to_tag();
        bad.push(0xff);
        assert_eq!(Speaks::from_tag(&bad), None, "not UTF-8");
    }

    #[test]
    fn the_side_with_the_lower_protocol_is_told_to_upgrade() {
        let old = Speaks {
            version: "0.1.0".into(),
            protocol: 1,
        };
        let new = Speaks {
            version: "0.2.0".into(),
            protocol: 2,
        };
        let m = differ(&new, "the data server", Some(&old));
        assert!(m.contains("this client is rome 0.2.0 (protocol 2)"), "{m}");
        assert!(
            m.contains("the data server is rome 0.1.0 (protocol 1)"),
            "{m}"
        );
        assert!(
            m.ends_with("upgrade the data server to rome 0.2.0 or later"),
            "{m}"
        );
        let m = differ(&old, "r1/base", Some(&new));
        assert!(
            m.ends_with("upgrade this client to rome 0.2.0 or later"),
            "{m}"
        );
        let m = differ(&new, "r1/base", None);
        assert!(m.contains("did not say its version"), "{m}");
        assert!(m.ends_with("upgrade r1/base to rome 0.2.0 or later"), "{m}");
    }
}

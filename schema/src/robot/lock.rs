//! The lock token shared by the base and the cameras: grants, releases,
//! the holder seen in a state, the record kept in storage, and the
//! server's command counters.

use serde::{Deserialize, Serialize};

/// `lock`: the grant; every later command of the holder carries `fence`.
///
/// ```text
/// {"holder":"6f1c2d-3","fence":1732280000001,"ttl_ms":2500}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockGrant {
    /// The owner id the lock was granted to (`anonymous` without one).
    pub holder: String,
    /// The fencing number of this grant.
    pub fence: u64,
    /// The grant lapses this long after the holder's last command or renewal.
    pub ttl_ms: u64,
}

/// `unlock`: the lock is free again.
///
/// ```text
/// {"released":true,"fence":1732280000001}
/// ```
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Unlocked {
    /// Always true: a failed unlock is an error reply.
    pub released: bool,
    /// The fence of the grant that ended.
    pub fence: u64,
}

/// `stats` (every hardware server): what the server has carried out, so
/// a repeat carried out twice shows. Answered at once, never queued.
///
/// ```text
/// {"executed":1200,"with_id":310,"answered_from_memory":4,"ids_executed_twice":0,"suppressed":0}
/// ```
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CommandStats {
    /// Device commands carried out (locks not counted).
    pub executed: u64,
    /// Of those, the ones that carried a request id (`op=`).
    pub with_id: u64,
    /// Repeats of a request id answered from memory without acting.
    pub answered_from_memory: u64,
    /// Request ids carried out more than once (kept for the last
    /// 65 536 ids): 0 unless a repeat was acted on.
    pub ids_executed_twice: u64,
    /// Commands that act refused because a higher priority suppressed
    /// them (`suppress_ms`).
    #[serde(default)]
    pub suppressed: u64,
}

/// Who holds a device's lock (in the state stream and the storage).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockInfo {
    /// The owner id.
    pub holder: String,
    /// The grant's fencing number.
    pub fence: u64,
}

/// A device's lock state as kept in the storage
/// (`<root>/store/robot/<robot>/<device>/lock`).
///
/// ```text
/// {"holder":{"holder":"6f1c2d-3","fence":17},"last_fence":17,"ttl_ms":2500}
/// ```
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct LockRecord {
    /// The current holder, if any.
    pub holder: Option<LockInfo>,
    /// The last fence granted: a restarted server grants above it.
    pub last_fence: u64,
    /// The holder's grant life, ms.
    pub ttl_ms: u64,
}

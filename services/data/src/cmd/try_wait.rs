use super::{Applied, Params};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::param;
use rome_schema::{ErrorReply, Name};

/// Non-blocking down() (the thesis' `down_nowait()`): takes a unit if one
/// is free and no wait is queued before it.
///
/// ```text
/// get rome/data/try-wait/XYZ?op=c7-14   -> {"name":"XYZ","acquired":true,"value":0}
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TryWait {
    /// The semaphore.
    pub name: Name,
    /// Idempotency id.
    pub op: Option<String>,
}

impl TryWait {
    /// Parses `op`.
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        params.finish("try-wait", &[param::OP])?;
        Ok(TryWait { name, op })
    }

    /// Tries to take a unit.
    pub fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.try_wait(
            &self.name,
            self.op.as_deref(),
            now,
        )?))
    }
}

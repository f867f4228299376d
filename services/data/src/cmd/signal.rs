use super::{Applied, Params};
use crate::store::Store;
use rome_schema::data::param;
use rome_schema::{ErrorReply, Name};
use std::time::Instant;

/// up(): adds a unit, handing it to the first queued wait if there is one
/// (the thesis' `DataSignal(DS, "$XYZ")`).
///
/// ```text
/// get rome/data/signal/XYZ?op=c7-13   -> {"name":"XYZ","value":0,"woke":true}
/// put rome/data/signal/XYZ            (no reply; any payload)
/// ```
///
/// `op` makes a retry safe: the same id signals once.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Signal {
    /// The semaphore.
    pub name: Name,
    /// Idempotency id.
    pub op: Option<String>,
}

impl Signal {
    /// Parses `op`.
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        params.finish("signal", &[param::OP])?;
        Ok(Signal { name, op })
    }

    /// Signals.
    pub fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        let signalled = store.signal(&self.name, self.op.as_deref(), now)?;
        let mut applied = Applied::reply(&signalled.reply);
        applied.grants = signalled.grants;
        Ok(applied)
    }
}

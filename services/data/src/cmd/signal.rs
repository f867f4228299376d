use super::{Applied, Params};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::param;
use rome_schema::{ErrorReply, Name};

/// up(): adds a unit, handing it to the first queued wait if there is one
/// (the thesis' `DataSignal(DS, "$XYZ")`).
///
/// ```text
/// get rome/data/signal/XYZ?op=c7-13   -> {"name":"XYZ","value":0,"woke":true}
/// put rome/data/signal/XYZ            (no reply; any payload)
/// ```
///
/// `op` makes a retry safe: the same id signals once. With `owner` and
/// `undo=true` the signal gives back a unit that owner took with an undo
/// wait (refused if it holds none):
///
/// ```text
/// get rome/data/signal/passage/J?op=c7-17;owner=c7;undo=true
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Signal {
    /// The semaphore.
    pub name: Name,
    /// Idempotency id.
    pub op: Option<String>,
    /// The owner giving back a unit it holds with `undo`.
    pub undo_owner: Option<String>,
}

impl Signal {
    /// Parses `op`, `owner` and `undo`.
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        let owner = params.take_id(param::OWNER)?;
        let undo = params.take_bool(param::UNDO)?;
        params.finish("signal", &[param::OP, param::OWNER, param::UNDO])?;
        let undo_owner = match (owner, undo) {
            (Some(owner), true) => Some(owner),
            (None, true) => {
                return Err(ErrorReply::new(
                    rome_schema::ErrorCode::BadParameter,
                    "an undo signal names the owner whose unit it gives back (owner=ID)",
                ))
            }
            // An owner alone changes nothing: a plain signal.
            (_, false) => None,
        };
        Ok(Signal {
            name,
            op,
            undo_owner,
        })
    }

    /// Signals.
    pub fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        let signalled = store.signal_as(
            &self.name,
            self.op.as_deref(),
            self.undo_owner.as_deref(),
            now,
        )?;
        let mut applied = Applied::reply(&signalled.reply);
        applied.grants = signalled.grants;
        Ok(applied)
    }
}

use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Signal;
use rome_schema::ErrorReply;

impl Apply for Signal {
    /// Signals; the waits it grants are answered by the server.
    fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
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

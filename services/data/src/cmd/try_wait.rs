use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::TryWait;
use rome_schema::ErrorReply;

impl Apply for TryWait {
    /// Tries to take a unit.
    fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        let reply = store.try_wait(&self.name, self.op.as_deref(), now)?;
        Ok(Applied::reply(&reply))
    }
}

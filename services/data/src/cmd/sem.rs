use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Read;
use rome_schema::ErrorReply;

impl Apply for Read {
    /// Reads the semaphore's state.
    fn apply(self, store: &mut Store, _: Instant) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.semaphore(&self.name)?))
    }
}

use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Create;
use rome_schema::ErrorReply;

impl Apply for Create {
    /// Creates the semaphore, or leaves one that exists as it is.
    fn apply(self, store: &mut Store, _: Instant) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.create(&self.name, self.value)?))
    }
}

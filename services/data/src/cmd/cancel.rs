use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Cancel;
use rome_schema::ErrorReply;

impl Apply for Cancel {
    /// Gives up the wait (or answers `granted` if the unit came first).
    fn apply(self, store: &mut Store, _: Instant) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.cancel(&self.name, &self.ticket)?))
    }
}

use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::History;
use rome_schema::ErrorReply;

impl Apply for History {
    /// Reads or sets the length.
    fn apply(self, store: &mut Store, _: Instant) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.history(&self.name, self.len)?))
    }
}

use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Ack;
use rome_schema::ErrorReply;

impl Apply for Ack {
    /// Confirms the grant.
    fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.ack(&self.name, &self.ticket, now)?))
    }
}

use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Wait;
use rome_schema::data::WaitStatus;
use rome_schema::{encode, ErrorReply};

impl Apply for Wait {
    /// Takes a unit now, or asks the server to hold the query.
    fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        let reply = store.wait_undo(
            &self.name,
            self.ticket.as_deref(),
            self.owner.as_deref(),
            self.undo,
            now,
        )?;
        if reply.status == WaitStatus::Pending {
            return Ok(Applied {
                hold: Some((reply.ticket, self.hold)),
                ..Applied::default()
            });
        }
        Ok(Applied {
            reply: Some(encode(&reply)),
            ..Applied::default()
        })
    }
}

use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Set;
use rome_schema::ErrorReply;

impl Apply for Set {
    /// Commits the write; the commit is published on `watch/<name>`.
    fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        let written = store.set(&self.name, self.value, self.op.as_deref(), now)?;
        let mut applied = Applied::reply(&written.reply);
        applied.commit = written.commit;
        Ok(applied)
    }
}

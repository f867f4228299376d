use super::{Applied, Apply};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::request::Get;
use rome_schema::{encode, ErrorReply};

impl Apply for Get {
    /// Reads the value, as written.
    fn apply(self, store: &mut Store, _: Instant) -> Result<Applied, ErrorReply> {
        let value = store.get(&self.name, self.back)?;
        Ok(Applied {
            reply: Some(encode(value)),
            ..Applied::default()
        })
    }
}

use super::{Applied, Params};
use crate::store::Store;
use rome_schema::data::{param, MAX_HISTORY};
use rome_schema::{encode, ErrorReply, Name};

/// Reads a variable's value, or an older one from its history
/// (the thesis' `DataGetValue(DS, "PosX", -N)`).
///
/// ```text
/// get rome/data/var/PosX            -> 4
/// get rome/data/var/PosX?back=2     -> 2     (the value two writes ago)
/// ```
///
/// The reply payload is the JSON value itself, exactly as written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Get {
    /// The variable.
    pub name: Name,
    /// Steps back in the history; 0 is the current value.
    pub back: u32,
}

impl Get {
    /// Parses `back`.
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let back = params
            .take_int(param::BACK, 0, i128::from(MAX_HISTORY) - 1)?
            .unwrap_or(0) as u32;
        params.finish("var", &[param::BACK])?;
        Ok(Get { name, back })
    }

    /// Reads the value.
    pub fn apply(self, store: &Store) -> Result<Applied, ErrorReply> {
        let value = store.get(&self.name, self.back)?;
        Ok(Applied {
            reply: Some(encode(value)),
            ..Applied::default()
        })
    }
}

use super::{Applied, Params};
use crate::store::Store;
use rome_schema::data::{param, MAX_HISTORY};
use rome_schema::{ErrorReply, Name};

/// Reads or sets how many values a variable keeps
/// (the thesis' `DataSetHistory(DS, "PosX", N)`).
///
/// ```text
/// get rome/data/history/PosX         -> {"name":"PosX","len":16,"stored":3,"seq":3}
/// get rome/data/history/PosX?len=5   -> {"name":"PosX","len":5,"stored":3,"seq":3}
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct History {
    /// The variable.
    pub name: Name,
    /// The new length, if setting.
    pub len: Option<u32>,
}

impl History {
    /// Parses `len` (1 ..= MAX_HISTORY).
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let len = params
            .take_int(param::LEN, 1, i128::from(MAX_HISTORY))?
            .map(|n| n as u32);
        params.finish("history", &[param::LEN])?;
        Ok(History { name, len })
    }

    /// Reads or sets the length.
    pub fn apply(self, store: &mut Store) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.history(&self.name, self.len)?))
    }
}

use super::{Applied, Params};
use crate::store::Store;
use rome_schema::data::{param, MAX_SEMAPHORE_VALUE};
use rome_schema::{ErrorCode, ErrorReply, Name};

/// Creates a semaphore with an initial value
/// (the thesis' `DataCreateSemaphore(DS, "$XYZ", 1)`).
///
/// ```text
/// get rome/data/create/XYZ?value=1   -> {"name":"XYZ","created":true,"value":1}
/// ```
///
/// Creating one that exists changes nothing and answers `created: false`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Create {
    /// The semaphore.
    pub name: Name,
    /// Its initial value.
    pub value: u64,
}

impl Create {
    /// Parses the required `value`.
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let value = params
            .take_int(param::VALUE, 0, i128::from(MAX_SEMAPHORE_VALUE))?
            .ok_or_else(|| {
                ErrorReply::new(
                    ErrorCode::BadParameter,
                    format!("creating semaphore '{name}' needs its initial value: ?value=N"),
                )
            })? as u64;
        params.finish("create", &[param::VALUE])?;
        Ok(Create { name, value })
    }

    /// Creates it.
    pub fn apply(self, store: &mut Store) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.create(&self.name, self.value)?))
    }
}

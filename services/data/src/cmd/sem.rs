use super::{Applied, Params};
use crate::store::Store;
use rome_schema::{ErrorReply, Name};

/// Reads a semaphore's value and queue length.
///
/// ```text
/// get rome/data/sem/GoalData   -> {"name":"GoalData","value":0,"waiters":1}
/// ```
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Read {
    /// The semaphore.
    pub name: Name,
}

impl Read {
    /// Takes no parameters.
    pub fn parse(name: Name, params: Params) -> Result<Self, ErrorReply> {
        params.finish("sem", &[])?;
        Ok(Read { name })
    }

    /// Reads the state.
    pub fn apply(self, store: &Store) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.semaphore(&self.name)?))
    }
}

use super::Command;
use crate::data::SemState;
use crate::keys::DataOp;
use crate::{ErrorReply, Name, Params};

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

impl Command for Read {
    const OP: DataOp = DataOp::Sem;
    type Reply = SemState;

    fn name(&self) -> &Name {
        &self.name
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        Vec::new()
    }

    /// Takes no parameters.
    fn parse(name: Name, params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        params.finish("sem", &[])?;
        Ok(Read { name })
    }
}

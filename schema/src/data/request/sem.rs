use crate::data::SemState;
use crate::{ErrorReply, Name, Params};

request! {
    /// Reads a semaphore's value and queue length.
    ///
    /// ```text
    /// get rome/data/sem/GoalData   -> {"name":"GoalData","value":0,"waiters":1}
    /// ```
    #[derive(Debug, Clone, PartialEq, Eq)]
    Read: Sem -> SemState, "The semaphore." {
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

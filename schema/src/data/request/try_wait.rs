use crate::data::{param, TryWaitReply};
use crate::{ErrorReply, Name, Params};

request! {
    /// Non-blocking down() (the thesis' `down_nowait()`): takes a unit if one
    /// is free and no wait is queued before it.
    ///
    /// ```text
    /// get rome/data/try-wait/XYZ?op=c7-14   -> {"name":"XYZ","acquired":true,"value":0}
    /// ```
    #[derive(Debug, Clone, PartialEq, Eq)]
    TryWait: TryWait -> TryWaitReply, "The semaphore." {
        /// Idempotency id.
        pub op: Option<String>,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        self.op.iter().map(|op| (param::OP, op.clone())).collect()
    }

    /// Parses `op`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        params.finish("try-wait", &[param::OP])?;
        Ok(TryWait { name, op })
    }
}

use super::{push_undo, undo_owner};
use crate::data::{param, TryWaitReply};
use crate::{ErrorReply, Name, Params};

request! {
    /// Non-blocking down() (the thesis' `down_nowait()`): takes a unit if one
    /// is free and no wait is queued before it.
    ///
    /// ```text
    /// get rome/data/try-wait/XYZ?op=c7-14   -> {"name":"XYZ","acquired":true,"value":0}
    /// ```
    ///
    /// With `owner` and `undo=true` a unit taken stays on that owner's
    /// account, as an undo wait's does: it comes back by itself when the
    /// owner is gone, unless given back first with an undo signal.
    ///
    /// ```text
    /// get rome/data/try-wait/traffic/junction/012?op=c7-18;owner=c7;undo=true
    /// ```
    #[derive(Debug, Clone, PartialEq, Eq)]
    TryWait: TryWait -> TryWaitReply, "The semaphore." {
        /// Idempotency id.
        pub op: Option<String>,
        /// The owner a unit taken is kept for (`undo`).
        pub undo_owner: Option<String>,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        let mut params: Vec<_> = self.op.iter().map(|op| (param::OP, op.clone())).collect();
        push_undo(&mut params, &self.undo_owner);
        params
    }

    /// Parses `op`, `owner` and `undo`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        let undo_owner = undo_owner(&mut params, "try-wait")?;
        params.finish("try-wait", &[param::OP, param::OWNER, param::UNDO])?;
        Ok(TryWait {
            name,
            op,
            undo_owner,
        })
    }
}

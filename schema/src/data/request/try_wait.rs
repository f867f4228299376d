use super::{op_undo_params, parse_op_undo};
use crate::data::TryWaitReply;
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
        op_undo_params(&self.op, &self.undo_owner)
    }

    /// Parses `op`, `owner` and `undo`.
    fn parse(name: Name, params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let (op, undo_owner) = parse_op_undo(params, "try-wait")?;
        Ok(TryWait { name, op, undo_owner })
    }
}

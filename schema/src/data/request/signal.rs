use super::{op_undo_params, parse_op_undo};
use crate::data::SignalReply;
use crate::{ErrorReply, Name, Params};

request! {
    /// up(): adds a unit, handing it to the first queued wait if there is one
    /// (the thesis' `DataSignal(DS, "$XYZ")`).
    ///
    /// ```text
    /// get rome/data/signal/XYZ?op=c7-13   -> {"name":"XYZ","value":0,"woke":true}
    /// put rome/data/signal/XYZ            (no reply; any payload)
    /// ```
    ///
    /// `op` makes a retry safe: the same id signals once. With `owner` and
    /// `undo=true` the signal gives back a unit that owner took with an undo
    /// wait (refused if it holds none):
    ///
    /// ```text
    /// get rome/data/signal/passage/J?op=c7-17;owner=c7;undo=true
    /// ```
    #[derive(Debug, Clone, PartialEq, Eq)]
    Signal: Signal -> SignalReply, "The semaphore." {
        /// Idempotency id.
        pub op: Option<String>,
        /// The owner giving back a unit it holds with `undo`.
        pub undo_owner: Option<String>,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        op_undo_params(&self.op, &self.undo_owner)
    }

    /// Parses `op`, `owner` and `undo`.
    fn parse(name: Name, params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let (op, undo_owner) = parse_op_undo(params, "signal")?;
        Ok(Signal { name, op, undo_owner })
    }
}

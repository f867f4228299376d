use crate::data::{param, SignalReply};
use crate::{ErrorCode, ErrorReply, Name, Params};

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
        let mut params: Vec<_> = self.op.iter().map(|op| (param::OP, op.clone())).collect();
        if let Some(owner) = &self.undo_owner {
            params.push((param::OWNER, owner.clone()));
            params.push((param::UNDO, "true".to_string()));
        }
        params
    }

    /// Parses `op`, `owner` and `undo`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        let owner = params.take_id(param::OWNER)?;
        let undo = params.take_bool(param::UNDO)?;
        params.finish("signal", &[param::OP, param::OWNER, param::UNDO])?;
        let undo_owner = match (owner, undo) {
            (Some(owner), true) => Some(owner),
            (None, true) => {
                return Err(ErrorReply::new(
                    ErrorCode::BadParameter,
                    "an undo signal names the owner whose unit it gives back (owner=ID)",
                ))
            }
            // An owner alone changes nothing: a plain signal.
            (_, false) => None,
        };
        Ok(Signal {
            name,
            op,
            undo_owner,
        })
    }
}

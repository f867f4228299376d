use super::{op_undo_params, undo_owner};
use crate::data::{param, SignalReply, MAX_SEMAPHORE_VALUE};
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
    ///
    /// With `units=N` it adds N units at once (and gives back N undo units).
    ///
    /// ```text
    /// get rome/data/signal/traffic/lane/012-015/up?op=c7-19;owner=c7;undo=true;units=64
    /// ```
    #[derive(Debug, Clone, PartialEq, Eq)]
    Signal: Signal -> SignalReply, "The semaphore." {
        /// Idempotency id.
        pub op: Option<String>,
        /// The owner giving back a unit it holds with `undo`.
        pub undo_owner: Option<String>,
        /// How many units it adds at once (at least 1).
        pub units: u64,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        let mut params = op_undo_params(&self.op, &self.undo_owner);
        if self.units != 1 {
            params.push((param::UNITS, self.units.to_string()));
        }
        params
    }

    /// Parses `op`, `owner`, `undo` and `units`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        let undo_owner = undo_owner(&mut params, "signal")?;
        let units = params
            .take_int(param::UNITS, 1, i128::from(MAX_SEMAPHORE_VALUE))?
            .map_or(1, |v| v as u64);
        params.finish(
            "signal",
            &[param::OP, param::OWNER, param::UNDO, param::UNITS],
        )?;
        Ok(Signal {
            name,
            op,
            undo_owner,
            units,
        })
    }
}

use crate::data::{param, WaitReply, DEFAULT_HOLD_MS, MAX_HOLD_MS, MAX_SEMAPHORE_VALUE};
use crate::{ErrorReply, Name, Params};
use std::time::Duration;

request! {
    /// Blocking down() (the thesis' `DataWait(DS, "$XYZ")`): answered
    /// `granted` as soon as a unit is the ticket's, or `pending` after
    /// `hold_ms` (the client asks again with the same ticket, keeping its
    /// place in the queue).
    ///
    /// ```text
    /// get rome/data/wait/XYZ?ticket=c7-15;owner=c7;hold_ms=10000
    ///     -> {"name":"XYZ","ticket":"c7-15","status":"granted"}
    ///     -> {"name":"XYZ","ticket":"c7-15","status":"pending","position":2}
    /// get rome/data/wait/XYZ?hold_ms=3000        (anonymous, e.g. from z_get)
    ///     -> {"name":"XYZ","ticket":"anon-4","status":"timed_out"}
    /// ```
    ///
    /// With an `owner` (the last chunk of the client's liveliness token
    /// `rome/alive/client/<role>/<owner>`) a grant is provisional until
    /// `ack`; if the owner disappears first, its place is dropped and the
    /// unit goes back. An anonymous wait's grant is final, and it leaves the
    /// queue when its hold runs out.
    ///
    /// With `undo=true` (owner required) the confirmed unit stays on the
    /// owner's account: it comes back by itself when the owner is gone, unless
    /// the owner gave it back first with `signal?owner=…;undo=true`.
    ///
    /// ```text
    /// get rome/data/wait/passage/J?ticket=c7-16;owner=c7;undo=true
    /// ```
    ///
    /// With `units=N` the ticket takes N units at once, when it is first in
    /// the queue and N are free; those behind it wait meanwhile:
    ///
    /// ```text
    /// get rome/data/wait/traffic/lane/012-015/up?ticket=c7-18;owner=c7;undo=true;units=64
    /// ```
    #[derive(Debug, Clone, PartialEq, Eq)]
    Wait: Wait -> WaitReply, "The semaphore." {
        /// The wait's identity across retries.
        pub ticket: Option<String>,
        /// The waiting client's liveliness id.
        pub owner: Option<String>,
        /// How long the server may hold the query.
        pub hold: Duration,
        /// The unit stays on the owner's account until given back.
        pub undo: bool,
        /// How many units it takes at once (at least 1).
        pub units: u64,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        let mut params = Vec::with_capacity(4);
        if let Some(ticket) = &self.ticket {
            params.push((param::TICKET, ticket.clone()));
        }
        if let Some(owner) = &self.owner {
            params.push((param::OWNER, owner.clone()));
        }
        params.push((param::HOLD_MS, self.hold.as_millis().to_string()));
        if self.undo {
            params.push((param::UNDO, "true".to_string()));
        }
        if self.units != 1 {
            params.push((param::UNITS, self.units.to_string()));
        }
        params
    }

    /// Parses `ticket`, `owner`, `hold_ms`, `undo` and `units`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let ticket = params.take_id(param::TICKET)?;
        let owner = params.take_id(param::OWNER)?;
        let hold_ms = params
            .take_int(param::HOLD_MS, 0, i128::from(MAX_HOLD_MS))?
            .map_or(DEFAULT_HOLD_MS, |v| v as u64);
        let undo = params.take_bool(param::UNDO)?;
        let units = params
            .take_int(param::UNITS, 1, i128::from(MAX_SEMAPHORE_VALUE))?
            .map_or(1, |v| v as u64);
        params.finish(
            "wait",
            &[param::TICKET, param::OWNER, param::HOLD_MS, param::UNDO, param::UNITS],
        )?;
        Ok(Wait {
            name,
            ticket,
            owner,
            hold: Duration::from_millis(hold_ms),
            undo,
            units,
        })
    }
}

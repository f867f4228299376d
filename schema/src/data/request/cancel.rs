use super::required_ticket;
use crate::data::{param, WaitReply};
use crate::{ErrorReply, Name, Params};

request! {
    /// Gives up a queued wait.
    ///
    /// ```text
    /// get rome/data/cancel/XYZ?ticket=c7-15   -> {"name":"XYZ","ticket":"c7-15","status":"cancelled"}
    /// ```
    ///
    /// If the unit was granted in the meantime the answer is `granted`: the
    /// client must take it (and `ack`) instead of losing it.
    #[derive(Debug, Clone, PartialEq, Eq)]
    Cancel: Cancel -> WaitReply, "The semaphore." {
        /// The wait to give up.
        pub ticket: String,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        vec![(param::TICKET, self.ticket.clone())]
    }

    /// Parses the required `ticket`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let ticket = required_ticket("cancel", &mut params)?;
        params.finish("cancel", &[param::TICKET])?;
        Ok(Cancel { name, ticket })
    }
}

use super::required_ticket;
use crate::data::{param, WaitReply};
use crate::{ErrorReply, Name, Params};

request! {
    /// Confirms a granted wait: the unit is the client's for good.
    ///
    /// ```text
    /// get rome/data/ack/XYZ?ticket=c7-15   -> {"name":"XYZ","ticket":"c7-15","status":"confirmed"}
    /// ```
    ///
    /// `unknown` means the grant was taken back (the owner was seen gone):
    /// the client holds no unit and must wait again.
    #[derive(Debug, Clone, PartialEq, Eq)]
    Ack: Ack -> WaitReply, "The semaphore." {
        /// The granted wait.
        pub ticket: String,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        vec![(param::TICKET, self.ticket.clone())]
    }

    /// Parses the required `ticket`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let ticket = required_ticket("ack", &mut params)?;
        params.finish("ack", &[param::TICKET])?;
        Ok(Ack { name, ticket })
    }
}

use super::cancel::required_ticket;
use super::{Applied, Params};
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::data::param;
use rome_schema::{ErrorReply, Name};

/// Confirms a granted wait: the unit is the client's for good.
///
/// ```text
/// get rome/data/ack/XYZ?ticket=c7-15   -> {"name":"XYZ","ticket":"c7-15","status":"confirmed"}
/// ```
///
/// `unknown` means the grant was taken back (the owner was seen gone):
/// the client holds no unit and must wait again.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ack {
    /// The semaphore.
    pub name: Name,
    /// The granted wait.
    pub ticket: String,
}

impl Ack {
    /// Parses the required `ticket`.
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let ticket = required_ticket("ack", &mut params)?;
        params.finish("ack", &[param::TICKET])?;
        Ok(Ack { name, ticket })
    }

    /// Confirms.
    pub fn apply(self, store: &mut Store, now: Instant) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.ack(&self.name, &self.ticket, now)?))
    }
}

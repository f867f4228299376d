use super::{Applied, Params};
use crate::store::Store;
use rome_schema::data::param;
use rome_schema::{ErrorCode, ErrorReply, Name};

/// Gives up a queued wait.
///
/// ```text
/// get rome/data/cancel/XYZ?ticket=c7-15   -> {"name":"XYZ","ticket":"c7-15","status":"cancelled"}
/// ```
///
/// If the unit was granted in the meantime the answer is `granted`: the
/// client must take it (and `ack`) instead of losing it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Cancel {
    /// The semaphore.
    pub name: Name,
    /// The wait to give up.
    pub ticket: String,
}

/// Takes the required `ticket` parameter.
pub(super) fn required_ticket(op: &str, params: &mut Params) -> Result<String, ErrorReply> {
    params.take_id(param::TICKET)?.ok_or_else(|| {
        ErrorReply::new(
            ErrorCode::BadParameter,
            format!("'{op}' needs the ticket of the wait: ?ticket=ID"),
        )
    })
}

impl Cancel {
    /// Parses the required `ticket`.
    pub fn parse(name: Name, mut params: Params) -> Result<Self, ErrorReply> {
        let ticket = required_ticket("cancel", &mut params)?;
        params.finish("cancel", &[param::TICKET])?;
        Ok(Cancel { name, ticket })
    }

    /// Cancels.
    pub fn apply(self, store: &mut Store) -> Result<Applied, ErrorReply> {
        Ok(Applied::reply(&store.cancel(&self.name, &self.ticket)?))
    }
}

use crate::data::{param, SetReply, MAX_VALUE_BYTES};
use crate::{decode, encode, ErrorCode, ErrorReply, Name, Params};
use serde_json::Value;

request! {
    /// Acknowledged write: the reply comes after the value is committed, so
    /// the writer's next read sees it (read-your-writes). A plain Zenoh `put`
    /// on `var/<name>` writes too, without a reply.
    ///
    /// ```text
    /// get rome/data/set/PosX?op=c7-12  payload: 4  -> {"name":"PosX","seq":12}
    /// ```
    ///
    /// `op` makes a retry safe: the same id is committed once.
    #[derive(Debug, Clone, PartialEq)]
    Set: Set -> SetReply, "The variable." {
        /// The new value: any JSON.
        pub value: Value,
        /// Idempotency id.
        pub op: Option<String>,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        self.op.iter().map(|op| (param::OP, op.clone())).collect()
    }

    fn payload(&self) -> Option<Vec<u8>> {
        Some(encode(&self.value))
    }

    /// Parses the payload and `op`.
    fn parse(name: Name, mut params: Params, payload: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let op = params.take_id(param::OP)?;
        params.finish("set", &[param::OP])?;
        let value = value_from_payload(&name, payload)?;
        Ok(Set { name, value, op })
    }
}

/// Decodes a variable's value from a payload, naming the variable on error.
pub fn value_from_payload(name: &Name, payload: Option<&[u8]>) -> Result<Value, ErrorReply> {
    let bytes = payload.unwrap_or_default();
    if bytes.is_empty() {
        return Err(ErrorReply::new(
            ErrorCode::BadJson,
            format!("writing '{name}' needs a JSON value as payload (for example 4, \"text\" or {{\"x_mm\":1}}); the payload is empty"),
        ));
    }
    if bytes.len() > MAX_VALUE_BYTES {
        return Err(ErrorReply::new(
            ErrorCode::OutOfRange,
            format!(
                "value of '{name}' is {} bytes; the limit is {MAX_VALUE_BYTES} (bulk data belongs to the camera servers, not the data server)",
                bytes.len()
            ),
        ));
    }
    decode(bytes, &format!("value of '{name}'"))
        .map_err(|e| ErrorReply::new(ErrorCode::BadJson, e.to_string()))
}

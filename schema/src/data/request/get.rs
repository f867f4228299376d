use crate::data::{param, MAX_HISTORY};
use crate::{ErrorReply, Name, Params};
use serde_json::Value;

request! {
    /// Reads a variable's value, or an older one from its history
    /// (the thesis' `DataGetValue(DS, "PosX", -N)`).
    ///
    /// ```text
    /// get rome/data/var/PosX            -> 4
    /// get rome/data/var/PosX?back=2     -> 2     (the value two writes ago)
    /// ```
    ///
    /// The reply payload is the JSON value itself, exactly as written.
    #[derive(Debug, Clone, PartialEq, Eq)]
    Get: Var -> Value, "The variable." {
        /// Steps back in the history; 0 is the current value.
        pub back: u32,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        if self.back == 0 {
            Vec::new()
        } else {
            vec![(param::BACK, self.back.to_string())]
        }
    }

    /// Parses `back`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let back = params
            .take_int(param::BACK, 0, i128::from(MAX_HISTORY) - 1)?
            .unwrap_or(0) as u32;
        params.finish("var", &[param::BACK])?;
        Ok(Get { name, back })
    }
}

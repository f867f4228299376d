use crate::data::{param, CreateReply, MAX_SEMAPHORE_VALUE};
use crate::{ErrorCode, ErrorReply, Name, Params};

request! {
    /// Creates a semaphore with an initial value
    /// (the thesis' `DataCreateSemaphore(DS, "$XYZ", 1)`).
    ///
    /// ```text
    /// get rome/data/create/XYZ?value=1   -> {"name":"XYZ","created":true,"value":1}
    /// ```
    ///
    /// Creating one that exists changes nothing and answers `created: false`.
    #[derive(Debug, Clone, PartialEq, Eq)]
    Create: Create -> CreateReply, "The semaphore." {
        /// Its initial value.
        pub value: u64,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        vec![(param::VALUE, self.value.to_string())]
    }

    /// Parses the required `value`.
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let value = params
            .take_int(param::VALUE, 0, i128::from(MAX_SEMAPHORE_VALUE))?
            .ok_or_else(|| {
                ErrorReply::new(
                    ErrorCode::BadParameter,
                    format!("creating semaphore '{name}' needs its initial value: ?value=N"),
                )
            })? as u64;
        params.finish("create", &[param::VALUE])?;
        Ok(Create { name, value })
    }
}

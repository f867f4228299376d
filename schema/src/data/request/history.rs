use crate::data::{param, HistoryInfo, MAX_HISTORY};
use crate::{ErrorReply, Name, Params};

request! {
    /// Reads or sets how many values a variable keeps
    /// (the thesis' `DataSetHistory(DS, "PosX", N)`).
    ///
    /// ```text
    /// get rome/data/history/PosX         -> {"name":"PosX","len":16,"stored":3,"seq":3}
    /// get rome/data/history/PosX?len=5   -> {"name":"PosX","len":5,"stored":3,"seq":3}
    /// ```
    #[derive(Debug, Clone, PartialEq, Eq)]
    History: History -> HistoryInfo, "The variable." {
        /// The new length, if setting.
        pub len: Option<u32>,
    }

    fn params(&self) -> Vec<(&'static str, String)> {
        self.len
            .map(|len| (param::LEN, len.to_string()))
            .into_iter()
            .collect()
    }

    /// Parses `len` (1 ..= MAX_HISTORY).
    fn parse(name: Name, mut params: Params, _: Option<&[u8]>) -> Result<Self, ErrorReply> {
        let len = params
            .take_int(param::LEN, 1, i128::from(MAX_HISTORY))?
            .map(|n| n as u32);
        params.finish("history", &[param::LEN])?;
        Ok(History { name, len })
    }
}

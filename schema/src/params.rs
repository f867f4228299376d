//! Strict selector-parameter parsing shared by every request.

use crate::{ErrorCode, ErrorReply, Name};

/// The selector parameters of one request; each command takes what it
/// knows and [`Params::finish`] refuses whatever is left.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Params {
    pairs: Vec<(String, String)>,
}

impl Params {
    /// Collects parameters, passing over Zenoh's own (`_` prefix).
    pub fn new<'a>(pairs: impl IntoIterator<Item = (&'a str, &'a str)>) -> Self {
        Params {
            pairs: pairs
                .into_iter()
                .filter(|(k, _)| !k.starts_with('_'))
                .map(|(k, v)| (k.to_string(), v.to_string()))
                .collect(),
        }
    }

    /// Parses `a=1;b=x`, Zenoh's selector-parameter syntax (for tests and tools).
    pub fn parse(text: &str) -> Self {
        Params::new(
            text.split(';')
                .filter(|p| !p.is_empty())
                .map(|p| p.split_once('=').unwrap_or((p, ""))),
        )
    }

    fn take(&mut self, name: &str) -> Option<String> {
        let i = self.pairs.iter().position(|(k, _)| k == name)?;
        Some(self.pairs.remove(i).1)
    }

    /// Takes a parameter's raw text.
    pub fn take_text(&mut self, name: &str) -> Option<String> {
        self.take(name)
    }

    /// Takes a whole number within `min..=max`.
    pub fn take_int(
        &mut self,
        name: &str,
        min: i128,
        max: i128,
    ) -> Result<Option<i128>, ErrorReply> {
        let Some(text) = self.take(name) else {
            return Ok(None);
        };
        let value: i128 = text.trim().parse().map_err(|_| {
            ErrorReply::new(
                ErrorCode::WrongType,
                format!("parameter '{name}' must be a whole number, got '{text}'"),
            )
        })?;
        if value < min || value > max {
            return Err(ErrorReply::new(
                ErrorCode::OutOfRange,
                format!("parameter '{name}' must be between {min} and {max}, got {value}"),
            ));
        }
        Ok(Some(value))
    }

    /// Takes a flag: `true` or `false` (absent is `false`).
    pub fn take_bool(&mut self, name: &str) -> Result<bool, ErrorReply> {
        match self.take(name).as_deref().map(str::trim) {
            None | Some("false") => Ok(false),
            Some("true") => Ok(true),
            Some(other) => Err(ErrorReply::new(
                ErrorCode::WrongType,
                format!("parameter '{name}' must be true or false, got '{other}'"),
            )),
        }
    }

    /// Takes an id (ticket, owner, op): a single key chunk of letters,
    /// digits, `_`, `-`, `.`.
    pub fn take_id(&mut self, name: &str) -> Result<Option<String>, ErrorReply> {
        let Some(text) = self.take(name) else {
            return Ok(None);
        };
        if text.contains('/') || text.len() > 128 || Name::new(text.as_str()).is_err() {
            return Err(ErrorReply::new(
                ErrorCode::BadParameter,
                format!("parameter '{name}' must be 1 to 128 letters, digits, '_', '-' or '.', got '{text}'"),
            ));
        }
        Ok(Some(text))
    }

    /// Refuses whatever parameters the command did not take.
    pub fn finish(self, op: &str, known: &[&str]) -> Result<(), ErrorReply> {
        match self.pairs.first() {
            None => Ok(()),
            Some((k, _)) => Err(ErrorReply::new(
                ErrorCode::BadParameter,
                format!(
                    "'{op}' has no parameter '{k}'; it takes {}",
                    if known.is_empty() {
                        "none".to_string()
                    } else {
                        known.join(", ")
                    }
                ),
            )),
        }
    }
}

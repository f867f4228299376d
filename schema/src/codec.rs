//! One encode and one strict decode entry point for every JSON message.
//!
//! Decoding is strict: unknown fields are refused (every message type is
//! `deny_unknown_fields`) and the error names what was being decoded, so a
//! malformed payload gets an error a person can act on.

use serde::{de::DeserializeOwned, Serialize};

/// A payload could not be decoded.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum DecodeError {
    /// The bytes are not UTF-8.
    #[error("{what}: payload is not UTF-8 text")]
    NotUtf8 {
        /// What was being decoded.
        what: String,
    },
    /// The bytes are not JSON, or not JSON of the expected shape.
    #[error("{what}: {detail} (payload: {excerpt})")]
    Json {
        /// What was being decoded.
        what: String,
        /// serde_json's description, with line and column.
        detail: String,
        /// The start of the offending payload, for the log.
        excerpt: String,
    },
}

/// Encodes a message as compact JSON bytes.
pub fn encode<T: Serialize + ?Sized>(message: &T) -> Vec<u8> {
    // Serialising our own plain-data types cannot fail: no maps with
    // non-string keys, no custom serialisers that error.
    serde_json::to_vec(message).unwrap_or_else(|e| {
        format!("{{\"code\":\"bad_json\",\"message\":\"encode failed: {e}\"}}").into_bytes()
    })
}

/// Decodes JSON bytes into `T`, naming `what` in the error.
pub fn decode<T: DeserializeOwned>(bytes: &[u8], what: &str) -> Result<T, DecodeError> {
    let text = std::str::from_utf8(bytes).map_err(|_| DecodeError::NotUtf8 {
        what: what.to_string(),
    })?;
    serde_json::from_str(text).map_err(|e| DecodeError::Json {
        what: what.to_string(),
        detail: e.to_string(),
        excerpt: excerpt(text),
    })
}

fn excerpt(text: &str) -> String {
    const MAX: usize = 60;
    let trimmed = text.trim();
    if trimmed.is_empty() {
        return "empty".to_string();
    }
    match trimmed.char_indices().nth(MAX) {
        Some((cut, _)) => format!("{}…", &trimmed[..cut]),
        None => trimmed.to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::SetReply;

    #[test]
    fn round_trip() {
        let reply = SetReply {
            name: "PosX".into(),
            seq: 7,
        };
        let back: SetReply = decode(&encode(&reply), "set reply").unwrap();
        assert_eq!(back, reply);
    }

    #[test]
    fn unknown_field_is_refused_and_named() {
        let err = decode::<SetReply>(br#"{"name":"a","seq":1,"extra":2}"#, "set reply")
            .unwrap_err()
            .to_string();
        assert!(err.contains("set reply"), "{err}");
        assert!(err.contains("extra"), "{err}");
    }

    #[test]
    fn non_utf8_and_empty_are_named() {
        let err = decode::<SetReply>(&[0xff, 0xfe], "set reply").unwrap_err();
        assert!(matches!(err, DecodeError::NotUtf8 { .. }));
        let err = decode::<serde_json::Value>(b"  ", "value")
            .unwrap_err()
            .to_string();
        assert!(err.contains("empty"), "{err}");
    }
}

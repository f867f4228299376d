//! A program's presence: its liveliness token, and beside it, on the same
//! key, a queryable that says which build and protocol it speaks
//! (`rome_schema::version`). Also the attachment every request and reply
//! carries: the lock-step stamp, if any, then the version tag.

use rome_clock::Stamp;
use rome_schema::version::Speaks;
use std::time::Duration;
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::liveliness::LivelinessToken;
use zenoh::query::Queryable;
use zenoh::Session;

/// A program's liveliness token and its version queryable; dropping it
/// undeclares both.
pub struct Presence {
    _token: LivelinessToken,
    _about: Option<Queryable<()>>,
}

/// Declares the liveliness token `key` and, on the same key, a queryable
/// that answers [`Speaks::this`] as JSON. The token is what others rely
/// on (locks, undo units, `rome ls`), so only its failure is an error; a
/// version queryable that cannot be declared is logged and left out.
pub async fn declare(session: &Session, key: &str) -> zenoh::Result<Presence> {
    let about = session
        .declare_queryable(key)
        .callback({
            let body = rome_schema::encode(&Speaks::this());
            let own = key.to_string();
            // On the token's own key, not the query's (`<root>/alive/**`),
            // so the asker can tell the programs apart.
            move |q| {
                let reply = q
                    .reply(own.as_str(), body.clone())
                    .encoding(Encoding::APPLICATION_JSON);
                if let Err(e) = zenoh::Wait::wait(reply) {
                    tracing::debug!(error = %e, "version reply failed");
                }
            }
        })
        .await;
    let about = match about {
        Ok(q) => Some(q),
        Err(e) => {
            tracing::warn!(%key, error = %e, "the version queryable was not declared; `rome ls` will not show this program's version");
            None
        }
    };
    let token = session.liveliness().declare_token(key).await?;
    Ok(Presence {
        _token: token,
        _about: about,
    })
}

/// The versions said on every presence matching `keys` (a key expression
/// under `<root>/alive/`), by key. A reply that does not decode is left
/// out (anyone may answer a query), so a key missing here is a program
/// that said nothing: a build from before protocol versions.
pub async fn versions(
    session: &Session,
    keys: &str,
    timeout: Duration,
) -> zenoh::Result<Vec<(String, Speaks)>> {
    let replies = session
        .get(keys)
        .timeout(timeout)
        .consolidation(zenoh::query::ConsolidationMode::None)
        // Unbounded, as a bounded channel smaller than the number of local
        // answers would block before the receiver is returned.
        .with(flume::unbounded())
        .await?;
    let mut out = Vec::new();
    while let Ok(reply) = replies.recv_async().await {
        let Ok(sample) = reply.result() else { continue };
        let bytes = sample.payload().to_bytes();
        match rome_schema::decode::<Speaks>(&bytes, "version") {
            Ok(s) => out.push((sample.key_expr().to_string(), s)),
            Err(e) => {
                tracing::debug!(key = %sample.key_expr(), error = %e, "version reply skipped")
            }
        }
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    Ok(out)
}

/// The attachment of a request or reply: `stamp`, if any, then this
/// build's version tag.
pub fn attachment(stamp: Option<Stamp>) -> ZBytes {
    // Made once: every request and reply carries it.
    static TAG: std::sync::LazyLock<Vec<u8>> = std::sync::LazyLock::new(|| Speaks::this().to_tag());
    let mut b = Vec::with_capacity(Stamp::LEN + TAG.len());
    if let Some(s) = stamp {
        b.extend_from_slice(&s.to_bytes());
    }
    b.extend_from_slice(&TAG);
    ZBytes::from(b)
}

/// An attachment's stamp and version tag, each if it is there. Foreign
/// bytes are neither.
pub fn split(attachment: Option<&ZBytes>) -> (Option<Stamp>, Option<Speaks>) {
    let Some(a) = attachment else {
        return (None, None);
    };
    let bytes = a.to_bytes();
    let stamp = bytes.get(..Stamp::LEN).and_then(Stamp::from_bytes);
    let rest = if stamp.is_some() {
        &bytes[Stamp::LEN..]
    } else {
        &bytes[..]
    };
    (stamp, Speaks::from_tag(rest))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stamp_and_a_tag_are_told_apart() {
        let stamp = Stamp {
            time_ms: 5,
            round: 2,
            from: 9,
            seq: 1,
        };
        let (s, v) = split(Some(&attachment(Some(stamp))));
        assert_eq!(s, Some(stamp));
        assert_eq!(v, Some(Speaks::this()));
        let (s, v) = split(Some(&attachment(None)));
        assert_eq!((s, v), (None, Some(Speaks::this())));
        // A stamp alone, as a build from before versions sends it.
        let (s, v) = split(Some(&ZBytes::from(stamp.to_bytes().to_vec())));
        assert_eq!((s, v), (Some(stamp), None));
        let (s, v) = split(Some(&ZBytes::from(b"anything".to_vec())));
        assert_eq!((s, v), (None, None));
    }
}

//! A program's presence: its liveliness token, and beside it, on the same
//! key, a queryable that says which build and protocol it speaks
//! (`rome_schema::version`). Also the attachment every request and reply
//! carries: the lock-step stamp, if any, then the version tag.

use rome_clock::Stamp;
use rome_schema::version::Speaks;
use std::collections::{BTreeSet, HashMap};
use std::sync::{Arc, LazyLock, Mutex, MutexGuard, Weak};
use std::time::Duration;
use zenoh::bytes::{Encoding, ZBytes};
use zenoh::liveliness::LivelinessToken;
use zenoh::query::Queryable;
use zenoh::session::ZenohId;
use zenoh::{Session, Wait};

/// A program's liveliness token and its place on a version queryable;
/// dropping it undeclares both (the queryable once nobody else of its
/// session answers on it).
pub struct Presence {
    _token: LivelinessToken,
    _about: Option<About>,
}

/// Declares the liveliness token `key` and has [`Speaks::this`] answered
/// as JSON on the same key. The token is what others rely on (locks, undo
/// units, `rome ls`), so only its failure is an error; a version
/// queryable that cannot be declared is logged and left out.
///
/// The programs of one session with keys side by side (`…/client/nav/*`,
/// `…/server/robot/r1/*`) share one queryable that answers for each of
/// them: a process that runs a whole fleet holds a thousand presences, and
/// Zenoh matches every query against every queryable of the session. The
/// shared key stays within the one each program may declare on under
/// access control (`deploy/secure/router.json5`).
pub async fn declare(session: &Session, key: &str) -> zenoh::Result<Presence> {
    let about = About::join(session, key);
    let about = match about {
        Ok(a) => Some(a),
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

/// One key answered on a shared version queryable.
struct About {
    shared: Arc<Shared>,
    key: String,
}

/// A version queryable and the keys it answers for.
struct Shared {
    keys: Arc<Mutex<BTreeSet<String>>>,
    _queryable: Queryable<()>,
}

/// The shared queryables by session and key expression; gone once the
/// last [`About`] on one is dropped.
type Registry = HashMap<(ZenohId, String), Weak<Shared>>;
static SHARED: LazyLock<Mutex<Registry>> = LazyLock::new(Default::default);

impl About {
    fn join(session: &Session, key: &str) -> zenoh::Result<About> {
        // The key's siblings: its last chunk made a wildcard.
        let scope = match key.rsplit_once('/') {
            Some((parent, _)) => format!("{parent}/*"),
            None => key.to_string(),
        };
        let mut shared = SHARED.lock().unwrap_or_else(|p| p.into_inner());
        shared.retain(|_, w| w.strong_count() > 0);
        let id = (session.zid(), scope);
        let on = match shared.get(&id).and_then(Weak::upgrade) {
            Some(on) => on,
            None => {
                let on = Arc::new(Shared::declare(session, &id.1)?);
                shared.insert(id, Arc::downgrade(&on));
                on
            }
        };
        locked(&on.keys).insert(key.to_string());
        Ok(About {
            shared: on,
            key: key.to_string(),
        })
    }
}

impl Drop for About {
    fn drop(&mut self) {
        locked(&self.shared.keys).remove(&self.key);
    }
}

impl Shared {
    fn declare(session: &Session, scope: &str) -> zenoh::Result<Shared> {
        let keys: Arc<Mutex<BTreeSet<String>>> = Default::default();
        let body = rome_schema::encode(&Speaks::this());
        let answered = keys.clone();
        let queryable = session
            .declare_queryable(scope)
            .callback(move |q| {
                // On each program's own key, not the query's
                // (`<root>/alive/**`), so the asker can tell them apart.
                let keys: Vec<String> = locked(&answered)
                    .iter()
                    .filter(|k| {
                        zenoh::key_expr::keyexpr::new(k.as_str())
                            .is_ok_and(|k| q.key_expr().intersects(k))
                    })
                    .cloned()
                    .collect();
                for own in keys {
                    let reply = q
                        .reply(own.as_str(), body.clone())
                        .encoding(Encoding::APPLICATION_JSON);
                    if let Err(e) = zenoh::Wait::wait(reply) {
                        tracing::debug!(error = %e, "version reply failed");
                    }
                }
            })
            .wait()?;
        Ok(Shared {
            keys,
            _queryable: queryable,
        })
    }
}

fn locked<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|p| p.into_inner())
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

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn presences_side_by_side_answer_on_their_own_keys_until_dropped() {
        let mut config = zenoh::Config::default();
        config
            .insert_json5("scouting/multicast/enabled", "false")
            .unwrap();
        config.insert_json5("listen/endpoints", "[]").unwrap();
        let session = zenoh::open(config).await.expect("session");
        let a = declare(&session, "t/alive/client/nav/a").await.expect("a");
        let b = declare(&session, "t/alive/client/nav/b").await.expect("b");
        let c = declare(&session, "t/alive/server/data/c").await.expect("c");
        let said = |keys: &'static str| {
            let session = session.clone();
            async move {
                versions(&session, keys, Duration::from_secs(5))
                    .await
                    .expect("asked")
                    .into_iter()
                    .map(|(k, v)| {
                        assert_eq!(v, Speaks::this());
                        k
                    })
                    .collect::<Vec<_>>()
            }
        };
        assert_eq!(
            said("t/alive/**").await,
            [
                "t/alive/client/nav/a",
                "t/alive/client/nav/b",
                "t/alive/server/data/c"
            ]
        );
        // One program asked for on its own key: only it answers.
        assert_eq!(said("t/alive/client/nav/b").await, ["t/alive/client/nav/b"]);
        drop(a);
        assert_eq!(
            said("t/alive/**").await,
            ["t/alive/client/nav/b", "t/alive/server/data/c"]
        );
        drop((b, c));
        assert!(said("t/alive/**").await.is_empty());
        // A presence after all were gone declares the queryable again.
        let _d = declare(&session, "t/alive/client/nav/d").await.expect("d");
        assert_eq!(said("t/alive/**").await, ["t/alive/client/nav/d"]);
    }
}

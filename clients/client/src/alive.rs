//! Who is alive: every server and client declares a liveliness token
//! under `<root>/alive/...`; this replaces the thesis' name server.

use crate::ClientError;
use rome_schema::keys::AliveClass;
use rome_schema::Root;
use std::collections::BTreeSet;
use std::sync::{Arc, Mutex, PoisonError};
use std::time::Duration;
use zenoh::sample::{Sample, SampleKind};
use zenoh::Session;

/// One live participant.
#[derive(Debug, Clone, PartialEq, Eq, PartialOrd, Ord)]
pub struct Participant {
    /// `server` or `client`.
    pub class: &'static str,
    /// What it is: `data`, `cli`, `planner` …
    pub role: String,
    /// Its unique id.
    pub id: String,
    /// Its full liveliness key.
    pub key: String,
}

/// Lists every live server and client of the deployment, sorted.
pub async fn list(
    session: &Session,
    root: &Root,
    timeout: Duration,
) -> Result<Vec<Participant>, ClientError> {
    // A liveliness query alone can miss a token: this session answers the
    // tokens it already knows itself, and the query ends at the router's
    // final answer, which may overtake those local answers on a busy
    // machine (seen as a data server missing from the list, a few times
    // in a thousand). A subscriber has no end to overtake, so it is
    // declared first, and the list is everything either of them heard.
    let (heard, _subscriber) = hear(session, root, |key| Some(key.to_string())).await?;
    let mut keys = query(session, root, timeout).await?;
    {
        let heard = heard.lock().unwrap_or_else(PoisonError::into_inner);
        keys.extend(heard.alive.iter().cloned());
        keys.retain(|k| !heard.gone.contains(k));
    }
    let mut out = Vec::new();
    for key in keys {
        if let Some(alive) = root.parse_alive(&key) {
            out.push(Participant {
                class: match alive.class {
                    AliveClass::Server => "server",
                    AliveClass::Client => "client",
                },
                role: alive.role.to_string(),
                id: alive.id.to_string(),
                key: key.clone(),
            });
        }
    }
    out.sort();
    Ok(out)
}

/// The keys of the live tokens a liveliness query hears within `timeout`.
async fn query(
    session: &Session,
    root: &Root,
    timeout: Duration,
) -> Result<BTreeSet<String>, ClientError> {
    // Unbounded: the replies of this process's own tokens are delivered
    // before the get returns its receiver, so a bounded channel holding
    // fewer than there are tokens (the default 256; forty robots in one
    // process have more) would wait for a reader that never comes.
    let replies = session
        .liveliness()
        .get(root.alive_all())
        .timeout(timeout)
        .with(crate::call::replies())
        .await
        .map_err(ClientError::zenoh)?;
    let mut keys = BTreeSet::new();
    while let Ok(reply) = replies.recv_async().await {
        if let Ok(sample) = reply.result() {
            keys.insert(sample.key_expr().to_string());
        }
    }
    Ok(keys)
}

/// What a liveliness subscriber heard come and go, by a name taken from
/// each token's key.
#[derive(Default)]
struct Heard {
    alive: BTreeSet<String>,
    /// Gone since the subscriber began: an answer to a query, which may
    /// have been taken just before, does not bring them back.
    gone: BTreeSet<String>,
}

/// Subscribes (with the tokens already there) to every live token of the
/// deployment, each named by `name` from its key (`None`: not ours).
async fn hear(
    session: &Session,
    root: &Root,
    name: impl Fn(&str) -> Option<String> + Send + Sync + 'static,
) -> Result<(Arc<Mutex<Heard>>, zenoh::pubsub::Subscriber<()>), ClientError> {
    let heard = Arc::new(Mutex::new(Heard::default()));
    let sink = heard.clone();
    let subscriber = session
        .liveliness()
        .declare_subscriber(root.alive_all())
        .history(true)
        .callback(move |sample: Sample| {
            let Some(id) = name(sample.key_expr().as_str()) else {
                return;
            };
            let mut heard = sink.lock().unwrap_or_else(PoisonError::into_inner);
            if sample.kind() == SampleKind::Delete {
                heard.alive.remove(&id);
                heard.gone.insert(id);
            } else {
                heard.gone.remove(&id);
                heard.alive.insert(id);
            }
        })
        .await
        .map_err(ClientError::zenoh)?;
    Ok((heard, subscriber))
}

/// The build and protocol each live program says beside its liveliness
/// token, by token key. A program missing here said nothing: a build from
/// before protocol versions (or the router's access control hid it).
pub async fn versions(
    session: &Session,
    root: &Root,
    timeout: Duration,
) -> Result<Vec<(String, rome_schema::Speaks)>, ClientError> {
    rome_serve::presence::versions(session, &root.alive_all(), timeout)
        .await
        .map_err(ClientError::zenoh)
}

/// Waits until a server's liveliness token exists (`kind` `robot`, `id`
/// `r1/base`, as the server declares it): for starting clients right
/// after their servers without racing them.
pub async fn await_server(
    session: &Session,
    root: &Root,
    kind: &str,
    id: &str,
    timeout: Duration,
) -> Result<(), ClientError> {
    let key = root.alive_server(kind, id);
    let sub = session
        .liveliness()
        .declare_subscriber(&key)
        .history(true)
        .await
        .map_err(ClientError::zenoh)?;
    match tokio::time::timeout(timeout, sub.recv_async()).await {
        Ok(Ok(_)) => Ok(()),
        Ok(Err(e)) => Err(ClientError::zenoh(e)),
        Err(_) => Err(ClientError::NoReply {
            what: "server",
            key,
            waited: timeout,
        }),
    }
}

/// The ids of every live participant, kept up to date by a liveliness
/// subscriber: for a process that asks often (the dispatcher, every
/// round). A liveliness query each time waits for every peer's answer,
/// which with many peers in one process took the query's whole timeout.
pub struct Watch {
    seen: Arc<Mutex<Heard>>,
    _subscriber: zenoh::pubsub::Subscriber<()>,
}

impl Watch {
    /// Subscribes, then asks once (waiting up to `timeout`), so the
    /// watch starts with everyone already there.
    pub async fn start(
        session: &Session,
        root: &Root,
        timeout: Duration,
    ) -> Result<Watch, ClientError> {
        let keys = root.clone();
        let (seen, subscriber) = hear(session, root, move |key| {
            keys.parse_alive(key).map(|alive| alive.id.to_string())
        })
        .await?;
        // Its own subscriber already hears what the query may lose.
        let first = query(session, root, timeout).await?;
        {
            let mut s = seen.lock().unwrap_or_else(PoisonError::into_inner);
            for key in first {
                let Some(alive) = root.parse_alive(&key) else {
                    continue;
                };
                let id = alive.id.to_string();
                if !s.gone.contains(&id) {
                    s.alive.insert(id);
                }
            }
        }
        Ok(Watch {
            seen,
            _subscriber: subscriber,
        })
    }

    /// The ids alive now.
    pub fn ids(&self) -> BTreeSet<String> {
        self.seen
            .lock()
            .unwrap_or_else(PoisonError::into_inner)
            .alive
            .clone()
    }
}

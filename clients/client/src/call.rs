//! One query to a RoME server, as every client library sends it: the
//! selector, the band, the lock-step stamp, how the lock-step clock counts
//! the wait for the answer, and the answer told from a refusal and from
//! silence. [`crate::data`] and [`crate::robot`] put their own retry rules
//! around it (a data call retries until its deadline, a robot command
//! only while its request id makes a repeat safe).

use crate::ClientError;
use rome_schema::{decode, ErrorReply};
use std::future::Future;
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::handlers::Callback;
use zenoh::qos::Priority;
use zenoh::query::{ConsolidationMode, Reply};
use zenoh::Session;

/// The payload of the error reply Zenoh hands a querier itself when a
/// query times out.
const ZENOH_TIMEOUT: &[u8] = b"Timeout";

/// What one query brought back.
pub(crate) enum Answer {
    /// The server's reply.
    Reply {
        /// Its bytes.
        body: Vec<u8>,
        /// Its encoding.
        encoding: Encoding,
    },
    /// The server replied with an error.
    Refused(ErrorReply),
}

/// How the lock-step clock counts the wait for an answer.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Waiting {
    /// The server answers at once: the clock waits for the answer.
    Busy,
    /// The answer waits for another client or for the round's end: the
    /// clock goes on without it.
    Idle,
}

/// A reply channel for a query, unbounded and quiet. Unbounded: a server
/// in this process hands its replies over from its own task, and a full
/// channel would make it wait for this reader (in lock-step, where one
/// participant runs at a time, for ever). Quiet: a reply that comes after
/// the reader has gone (Zenoh's own timeout reply, after the answer was
/// taken; a second server's) is no one's business any more, where Zenoh's
/// own channels log each one as an error.
pub(crate) fn replies() -> (Callback<Reply>, flume::Receiver<Reply>) {
    let (tx, rx) = flume::unbounded();
    let callback = Callback::from(move |reply: Reply| {
        // Err only when the reader has gone: see above.
        let _ = tx.send(reply);
    });
    (callback, rx)
}

/// One query for `selector`; `Ok(None)` when nothing answered in `timeout`.
pub(crate) async fn attempt(
    session: &Session,
    selector: &str,
    payload: Option<&[u8]>,
    timeout: Duration,
    band: Priority,
    waiting: Waiting,
) -> Result<Option<Answer>, ClientError> {
    let mut get = session
        .get(selector)
        .timeout(timeout)
        // One server answers each key: its reply is handed over as it
        // arrives, not held until the server has finished with the query
        // (Zenoh's default, to pick the latest of several).
        .consolidation(ConsolidationMode::None)
        .priority(band)
        .with(replies());
    if let Some(p) = payload {
        get = get.payload(p.to_vec()).encoding(Encoding::APPLICATION_JSON);
    }
    // The version tag rides on every request, so that a server of
    // another protocol refuses it by name instead of misreading it.
    get = get.attachment(rome_serve::presence::attachment(rome_clock::stamp()));
    let replies = get.await.map_err(ClientError::zenoh)?;
    // Waits ride on the same receiver: the first reply is the answer.
    let answer = replies.recv_async();
    let answer = match waiting {
        Waiting::Busy => rome_clock::busy(answer).await,
        Waiting::Idle => rome_clock::idle(answer).await,
    };
    match answer {
        Ok(reply) => match reply.result() {
            Ok(sample) => Ok(Some(Answer::Reply {
                body: sample.payload().to_bytes().into_owned(),
                encoding: sample.encoding().clone(),
            })),
            Err(err) => Ok(refusal(&err.payload().to_bytes())?.map(Answer::Refused)),
        },
        Err(_) => Ok(None),
    }
}

/// A server's error reply, or `None` for Zenoh's local timeout (silence).
pub(crate) fn refusal(body: &[u8]) -> Result<Option<ErrorReply>, ClientError> {
    if body == ZENOH_TIMEOUT {
        return Ok(None);
    }
    Ok(Some(decode(body, "error reply")?))
}

/// How long a client asks a server's presence for its version, after the
/// server refused a request it did not understand.
const VERSION_PATIENCE: Duration = Duration::from_millis(500);

/// The error for a refusal `e` from the server called `name`, whose
/// liveliness token is `presence`: a request the server did not
/// understand, from a server of another protocol or one that says nothing
/// of its version, is named as versions differing.
pub(crate) async fn refused(
    session: &Session,
    e: ErrorReply,
    presence: &str,
    name: &str,
) -> ClientError {
    if !e.code.misunderstood() {
        return ClientError::Server(e);
    }
    let said = rome_serve::presence::versions(session, presence, VERSION_PATIENCE)
        .await
        .unwrap_or_default();
    let me = rome_schema::Speaks::this();
    // Several data servers may answer (a follower beside the leader):
    // any one of another protocol, or none at all, is worth naming.
    let other = said.iter().find(|(_, s)| s.protocol != me.protocol);
    if !said.is_empty() && other.is_none() {
        return ClientError::Server(e);
    }
    ClientError::Versions {
        versions: rome_schema::version::differ(&me, name, other.map(|(_, s)| s)),
        refused: e,
    }
}

/// A key with its selector parameters, `key?a=1;b=2`.
pub(crate) fn selector(key: &str, params: &[(&str, String)]) -> String {
    if params.is_empty() {
        return key.to_string();
    }
    let joined: Vec<String> = params.iter().map(|(k, v)| format!("{k}={v}")).collect();
    format!("{key}?{}", joined.join(";"))
}

/// `band`, unless this runs in a lock-step run, where every message goes
/// in the default band: Zenoh keeps one sender's messages in order only
/// within a band, and the clock's rounds rely on that order.
pub(crate) fn lockstep_band(band: Priority) -> Priority {
    if rome_clock::is_lockstep() {
        Priority::DEFAULT
    } else {
        band
    }
}

/// How long one attempt may wait at most in a run split into processes,
/// where a server holds a request until its round (see
/// [`rome_clock::Hold`]). The world may be held meanwhile for a party
/// still starting (`rome sim --parties`), for as long as that takes, so
/// the call's own timeout does not bound it: a server that dies or whose
/// link is lost ends the query at once, and the call fails then.
pub(crate) const HELD_PATIENCE: Duration = Duration::from_secs(3600);

/// Awaits `answer`, a request held for its round, saying once, after
/// `say_after`, that the request `key` is still waiting and why.
pub(crate) async fn held<T>(answer: impl Future<Output = T>, say_after: Duration, key: &str) -> T {
    tokio::pin!(answer);
    match tokio::time::timeout(say_after, &mut answer).await {
        Ok(a) => a,
        Err(_) => {
            tracing::warn!(
                %key,
                waited = ?say_after,
                "a request waits for its round: in a lock-step run split into processes its \
                 server holds it until every party follows the clock (`rome sim --parties`) and \
                 its round comes; waiting on while the server is there"
            );
            answer.await
        }
    }
}

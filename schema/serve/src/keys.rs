//! Keys a server publishes on again and again, declared to its session
//! once.
//!
//! Zenoh hands a publication on a key it was never told of to the
//! session's own subscribers by matching the key against every one of
//! them; on a declared key it keeps the matching subscribers beside the
//! declaration. A process that runs a whole fleet (`rome demo`,
//! `rome fleet`) holds thousands of subscriptions on one session while
//! each robot's devices publish many times a simulated second, and that
//! matching was the largest single cost of such a run.

use std::collections::HashMap;
use std::sync::Mutex;
use zenoh::key_expr::KeyExpr;
use zenoh::{Session, Wait};

/// Keys declared at the most; a publisher on more (a watch on every
/// variable ever written, say) publishes the rest undeclared, which is
/// slower but the same.
const MOST: usize = 1024;

/// Declared keys of one session, by the key's text.
pub struct Declared {
    session: Session,
    keys: Mutex<HashMap<String, KeyExpr<'static>>>,
}

impl Declared {
    /// None declared yet, on `session`.
    pub fn new(session: &Session) -> Self {
        Declared {
            session: session.clone(),
            keys: Mutex::new(HashMap::new()),
        }
    }

    /// `key` to publish on: declared to the session the first time it is
    /// asked for, while there is room. `None` for text that is no key
    /// expression.
    pub fn get(&self, key: &str) -> Option<KeyExpr<'static>> {
        let mut keys = self.keys.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(k) = keys.get(key) {
            return Some(k.clone());
        }
        let plain = KeyExpr::try_from(key.to_owned()).ok()?;
        if keys.len() >= MOST {
            return Some(plain);
        }
        // Declaring only tells this session (and its peers) of the key;
        // a failure leaves the plain key, which works as well.
        match self.session.declare_keyexpr(plain.clone()).wait() {
            Ok(declared) => {
                keys.insert(key.to_owned(), declared.clone());
                Some(declared)
            }
            Err(e) => {
                tracing::debug!(%key, error = %e, "key not declared");
                Some(plain)
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use zenoh::Config;

    #[tokio::test(flavor = "multi_thread", worker_threads = 2)]
    async fn a_publication_on_a_declared_key_reaches_the_sessions_subscribers() {
        let mut config = Config::default();
        config
            .insert_json5("scouting/multicast/enabled", "false")
            .unwrap();
        config.insert_json5("listen/endpoints", "[]").unwrap();
        let session = zenoh::open(config).await.expect("session");
        let sub = session.declare_subscriber("t/**").await.expect("sub");
        let keys = Declared::new(&session);
        let a = keys.get("t/a").expect("a key");
        assert_eq!(a.as_str(), "t/a");
        // The same declaration the second time, and a bad key refused.
        assert_eq!(keys.get("t/a").expect("a key").as_str(), "t/a");
        assert!(keys.get("t//b").is_none());
        session.put(&a, "1").await.expect("put");
        let got = sub.recv_async().await.expect("a sample");
        assert_eq!(got.key_expr().as_str(), "t/a");
        assert_eq!(got.payload().try_to_string().unwrap(), "1");
        // A subscription made after the declaration hears it too.
        let late = session.declare_subscriber("t/a").await.expect("late");
        session
            .put(&keys.get("t/a").unwrap(), "2")
            .await
            .expect("put");
        let got = late.recv_async().await.expect("a sample");
        assert_eq!(got.payload().try_to_string().unwrap(), "2");
    }
}

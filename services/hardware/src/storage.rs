//! A Zenoh storage in memory: the latest value of every key under a key
//! expression, answered to queries.
//!
//! A deployment with a router uses zenohd's storage manager on
//! `rome/store/**` (deploy/zenohd.json5); this one serves runs without a
//! router (`rome sim`, `rome storage`, tests). It keeps what the hardware
//! servers store there, their lock state, so a restarted server knows the
//! holder and the last fence.

use std::collections::BTreeMap;
use std::future::Future;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::sample::SampleKind;
use zenoh::Session;

/// Runs the storage on `key_expr` until `shutdown` completes.
pub async fn run(
    session: Session,
    key_expr: String,
    shutdown: impl Future<Output = ()>,
) -> Result<(), zenoh::Error> {
    let updates = session.declare_subscriber(&key_expr).await?;
    let queries = session.declare_queryable(&key_expr).complete(true).await?;
    let mut stored: BTreeMap<String, (Vec<u8>, Encoding)> = BTreeMap::new();
    tracing::info!(%key_expr, "storage ready");
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            biased;
            _ = &mut shutdown => break,
            Ok(sample) = updates.recv_async() => {
                let key = sample.key_expr().as_str().to_string();
                match sample.kind() {
                    SampleKind::Put => {
                        stored.insert(key, (sample.payload().to_bytes().into_owned(), sample.encoding().clone()));
                    }
                    SampleKind::Delete => {
                        stored.remove(&key);
                    }
                }
            }
            Ok(query) = queries.recv_async() => {
                for (key, (bytes, encoding)) in &stored {
                    let Ok(ke) = KeyExpr::try_from(key.as_str()) else { continue };
                    if query.key_expr().intersects(&ke) {
                        if let Err(e) = query.reply(ke, bytes.clone()).encoding(encoding.clone()).await {
                            tracing::warn!(%key, error = %e, "storage reply failed");
                        }
                    }
                }
            }
        }
    }
    Ok(())
}

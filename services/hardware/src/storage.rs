//! A Zenoh storage: the latest value of every key under a key expression,
//! answered to queries, kept in memory or also in a redb file.
//!
//! It keeps what the hardware servers store under `<root>/store/**`, their
//! lock state, so a restarted server knows the holder and the last fence.
//! `rome router` runs it on a file, so the records outlive the router too;
//! `rome sim` and `rome storage` run it for deployments without a router.

use redb::{Database, Durability, ReadableDatabase, ReadableTable, TableDefinition};
use rome_schema::Root;
use std::collections::BTreeMap;
use std::future::Future;
use std::path::{Path, PathBuf};
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::sample::SampleKind;
use zenoh::Session;

/// key -> payload, and key -> encoding.
const PAYLOADS: TableDefinition<&str, &[u8]> = TableDefinition::new("payloads");
const ENCODINGS: TableDefinition<&str, &str> = TableDefinition::new("encodings");

/// A storage's file could not be opened, read or written.
#[derive(Debug, thiserror::Error)]
#[error("storage file {path}: {detail}")]
pub struct FileError {
    /// The file.
    pub path: PathBuf,
    /// What went wrong.
    pub detail: String,
}

/// The file behind a storage: every put and delete is on disk (fsync)
/// before the next sample is taken.
pub struct StorageFile {
    db: Database,
    path: PathBuf,
}

impl StorageFile {
    /// Opens (or creates) the file, and its directory.
    pub fn open(path: &Path) -> Result<StorageFile, FileError> {
        let failed = |detail: String| FileError {
            path: path.to_path_buf(),
            detail,
        };
        if let Some(dir) = path.parent() {
            std::fs::create_dir_all(dir).map_err(|e| failed(e.to_string()))?;
        }
        let db = Database::create(path).map_err(|e| match e {
            redb::DatabaseError::DatabaseAlreadyOpen => failed(
                "in use by another storage (give each its own file, or run one in memory)".into(),
            ),
            e => failed(e.to_string()),
        })?;
        let file = StorageFile {
            db,
            path: path.to_path_buf(),
        };
        file.write(|tx| {
            tx.open_table(PAYLOADS)?;
            tx.open_table(ENCODINGS)?;
            Ok(())
        })?;
        Ok(file)
    }

    /// The file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn failed(&self, e: impl std::fmt::Display) -> FileError {
        FileError {
            path: self.path.clone(),
            detail: e.to_string(),
        }
    }

    fn write(
        &self,
        f: impl FnOnce(&redb::WriteTransaction) -> Result<(), redb::Error>,
    ) -> Result<(), FileError> {
        let mut tx = self.db.begin_write().map_err(|e| self.failed(e))?;
        tx.set_durability(Durability::Immediate)
            .map_err(|e| self.failed(e))?;
        f(&tx).map_err(|e| self.failed(e))?;
        tx.commit().map_err(|e| self.failed(e))
    }

    fn load(&self) -> Result<BTreeMap<String, (Vec<u8>, Encoding)>, FileError> {
        let fail = |e: redb::Error| self.failed(e);
        let tx = self.db.begin_read().map_err(|e| fail(e.into()))?;
        let payloads = tx.open_table(PAYLOADS).map_err(|e| fail(e.into()))?;
        let encodings = tx.open_table(ENCODINGS).map_err(|e| fail(e.into()))?;
        let mut out = BTreeMap::new();
        for entry in payloads.iter().map_err(|e| fail(e.into()))? {
            let (k, v) = entry.map_err(|e| fail(e.into()))?;
            let encoding = encodings
                .get(k.value())
                .map_err(|e| fail(e.into()))?
                .map_or(Encoding::default(), |e| {
                    Encoding::from(e.value().to_string())
                });
            out.insert(k.value().to_string(), (v.value().to_vec(), encoding));
        }
        Ok(out)
    }

    fn put(&self, key: &str, payload: &[u8], encoding: &Encoding) -> Result<(), FileError> {
        self.write(|tx| {
            tx.open_table(PAYLOADS)?.insert(key, payload)?;
            tx.open_table(ENCODINGS)?
                .insert(key, encoding.to_string().as_str())?;
            Ok(())
        })
    }

    fn delete(&self, key: &str) -> Result<(), FileError> {
        self.write(|tx| {
            tx.open_table(PAYLOADS)?.remove(key)?;
            tx.open_table(ENCODINGS)?.remove(key)?;
            Ok(())
        })
    }
}

/// The liveliness kind of a storage: `<root>/alive/server/store/<zid>`,
/// declared once it takes samples, so a hardware server can store its lock
/// record again when one comes (back) up.
pub const STORE_KIND: &str = "store";

/// Runs the storage on `key_expr` in memory until `shutdown` completes.
pub async fn run(
    session: Session,
    root: &Root,
    key_expr: String,
    shutdown: impl Future<Output = ()>,
) -> Result<(), zenoh::Error> {
    run_on(session, root, key_expr, None, shutdown).await
}

/// Runs the storage on `key_expr`, loaded from and written through to
/// `file` when given, until `shutdown` completes. A write that fails is
/// logged and the value kept in memory; the storage goes on serving.
pub async fn run_on(
    session: Session,
    root: &Root,
    key_expr: String,
    file: Option<StorageFile>,
    shutdown: impl Future<Output = ()>,
) -> Result<(), zenoh::Error> {
    let mut stored: BTreeMap<String, (Vec<u8>, Encoding)> = match &file {
        Some(f) => f
            .load()
            .inspect_err(|e| tracing::error!(error = %e, "storage not started"))?,
        None => BTreeMap::new(),
    };
    let updates = session.declare_subscriber(&key_expr).await?;
    let queries = session.declare_queryable(&key_expr).complete(true).await?;
    let alive = root.alive_server(STORE_KIND, &session.zid().to_string());
    let _token = rome_serve::presence::declare(&session, &alive).await?;
    tracing::info!(%key_expr, records = stored.len(), file = ?file.as_ref().map(|f| f.path.display().to_string()), "storage ready");
    tokio::pin!(shutdown);
    loop {
        tokio::select! {
            biased;
            _ = &mut shutdown => break,
            Ok(sample) = updates.recv_async() => {
                let key = sample.key_expr().as_str().to_string();
                let kept = match sample.kind() {
                    SampleKind::Put => {
                        let payload = sample.payload().to_bytes().into_owned();
                        let kept = file.as_ref().map_or(Ok(()), |f| f.put(&key, &payload, sample.encoding()));
                        stored.insert(key.clone(), (payload, sample.encoding().clone()));
                        kept
                    }
                    SampleKind::Delete => {
                        stored.remove(&key);
                        file.as_ref().map_or(Ok(()), |f| f.delete(&key))
                    }
                };
                if let Err(e) = kept {
                    tracing::error!(%key, error = %e, "stored in memory only");
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

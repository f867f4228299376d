//! The data server's state on disk, in one redb file.
//!
//! The store stays in memory; what a request changed ([`Changes`]) is
//! written in one transaction before the request is answered. Each key is
//! written as it is now, or removed if it is gone, so the file always holds
//! the state after the last committed request and nothing in between.
//!
//! Tables (keys and values; values are JSON unless said otherwise):
//!
//! ```text
//! vars     name            -> {"len":L,"seq":S}
//! values   (name, seq)     -> the value committed as number seq
//! sems     name            -> {"value":V,"queue":[ticket,...]}
//! tickets  ticket          -> {"sem":..,"owner":..,"granted":bool,"undo":bool}
//! held     (sem, owner)    -> units (u64)
//! ops      op id           -> {"at_ms":unix ms,"reply":<remembered reply>}
//! meta     "next_anonymous"-> u64
//!          "log_seq"       -> the last log record the file covers
//! ```
//!
//! Each write is committed to the file unsynced and appended to the
//! write-ahead log ([`log`], `DIR/data.log`); syncing the log is what
//! makes a write durable, and opening applies the log's records the file
//! does not cover yet. The write's edits ([`edit`]) are the log record.
//!
//! Times are not kept: a store loaded from disk treats every queued place,
//! grant and held unit as made at load time, so their owners get the whole
//! grace period to show they are alive (or to ask again) after a restart.

use super::{Changes, Held, Remembered, Sem, Store, Ticket, TicketState, Var};
use rome_clock::Instant;
use rome_schema::Name;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use std::sync::{Mutex, PoisonError};

use redb::{Database, Durability, ReadableDatabase, ReadableTable};

mod edit;
mod log;

use edit::{Edit, HELD, META, OPS, SEMS, TICKETS, VALUES, VARS};
pub use log::LOG_NAME;

const NEXT_ANONYMOUS: &str = "next_anonymous";
const LOG_SEQ: &str = "log_seq";

/// The file name inside a data directory.
pub const FILE_NAME: &str = "data.redb";

/// Why the state on disk could not be opened, read or written.
#[derive(Debug, thiserror::Error)]
pub enum DiskError {
    /// Another process has the file open.
    #[error("{path} is in use by another data server; give each data server its own --data-dir (or run one with --in-memory)")]
    InUse {
        /// The file.
        path: PathBuf,
    },
    /// The directory could not be made.
    #[error("could not create the data directory {path}: {detail}")]
    Directory {
        /// The directory.
        path: PathBuf,
        /// The operating system's error.
        detail: String,
    },
    /// redb refused or failed.
    #[error("{path}: {detail}")]
    Store {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        detail: String,
    },
    /// A record in the file does not decode.
    #[error("{path}: the record '{key}' in table '{table}' is damaged ({detail}); move the file away to start empty")]
    Damaged {
        /// The file.
        path: PathBuf,
        /// The table.
        table: &'static str,
        /// The record's key.
        key: String,
        /// The decoder's error.
        detail: String,
    },
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct VarRecord {
    len: u32,
    seq: u64,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct SemRecord {
    value: u64,
    queue: Vec<String>,
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct TicketRecord {
    sem: String,
    owner: Option<String>,
    granted: bool,
    undo: bool,
    /// Absent in files written before waits could take several units.
    #[serde(default = "one", skip_serializing_if = "is_one")]
    units: u64,
}

fn one() -> u64 {
    1
}

fn is_one(n: &u64) -> bool {
    *n == 1
}

#[derive(Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
struct OpRecord {
    at_ms: u64,
    reply: Remembered,
}

/// How hard a write is pushed to the disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Flush {
    /// On disk (fsync) before the call returns: for anything answered.
    Sync,
    /// Written, and on disk with the next `Sync` (plain puts, which have
    /// no reply to promise anything).
    Later,
}

/// The open state file of one data server, and its log.
pub struct Disk {
    db: Database,
    path: PathBuf,
    log: Mutex<log::Log>,
}

impl std::fmt::Debug for Disk {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Disk").field("path", &self.path).finish()
    }
}

fn unix_ms(t: SystemTime) -> u64 {
    t.duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_millis() as u64)
}

impl Disk {
    /// Opens (or creates) `dir/data.redb`, making `dir` if needed.
    pub fn open(dir: &Path) -> Result<Disk, DiskError> {
        std::fs::create_dir_all(dir).map_err(|e| DiskError::Directory {
            path: dir.to_path_buf(),
            detail: e.to_string(),
        })?;
        let path = dir.join(FILE_NAME);
        let db = Database::create(&path).map_err(|e| match e {
            redb::DatabaseError::DatabaseAlreadyOpen => DiskError::InUse { path: path.clone() },
            e => DiskError::Store {
                path: path.clone(),
                detail: e.to_string(),
            },
        })?;
        // Every table exists from the start, so reads need no special case.
        let after = (|| -> Result<u64, redb::Error> {
            let mut tx = db.begin_write()?;
            tx.set_durability(Durability::Immediate)?;
            edit::apply(&tx, &[])?;
            let seq = tx.open_table(META)?.get(LOG_SEQ)?.map_or(0, |v| v.value());
            tx.commit()?;
            Ok(seq)
        })()
        .map_err(|e| DiskError::Store {
            path: path.clone(),
            detail: e.to_string(),
        })?;
        let log_path = dir.join(LOG_NAME);
        let log_failed = |e: std::io::Error| DiskError::Store {
            path: log_path.clone(),
            detail: e.to_string(),
        };
        let (log, records) = log::Log::open(&log_path, after).map_err(log_failed)?;
        let disk = Disk {
            db,
            path,
            log: Mutex::new(log),
        };
        // What was answered but is not yet in the file: applied, and the
        // file synced, before the log starts again over those records. With
        // none, the file already covers all the log holds.
        let mut edits = Vec::new();
        for (seq, payload) in &records {
            edits.extend(edit::decode(payload).map_err(|e| DiskError::Damaged {
                path: log_path.clone(),
                table: "log",
                key: seq.to_string(),
                detail: e,
            })?);
        }
        let mut log = disk.log.lock().unwrap_or_else(PoisonError::into_inner);
        if !records.is_empty() {
            disk.checkpoint(&log, &edits)?;
        }
        log.restart().map_err(log_failed)?;
        drop(log);
        Ok(disk)
    }

    /// The state file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    fn failed(&self, e: impl std::fmt::Display) -> DiskError {
        DiskError::Store {
            path: self.path.clone(),
            detail: e.to_string(),
        }
    }

    /// Commits `edits` to the file unsynced and appends them to the log,
    /// which is synced if `flush` says so. A write the log has no room for
    /// is a checkpoint instead.
    fn commit(&self, edits: &[Edit], flush: Flush) -> Result<(), DiskError> {
        let mut log = self.log.lock().unwrap_or_else(PoisonError::into_inner);
        let record = edit::encode(edits);
        if !log.fits(record.len()) {
            self.checkpoint(&log, edits)?;
            return log.restart().map_err(|e| self.log_failed(e));
        }
        let mut tx = self.db.begin_write().map_err(|e| self.failed(e))?;
        tx.set_durability(Durability::None)
            .map_err(|e| self.failed(e))?;
        edit::apply(&tx, edits).map_err(|e| self.failed(e))?;
        tx.commit().map_err(|e| self.failed(e))?;
        log.append(&record).map_err(|e| self.log_failed(e))?;
        if flush == Flush::Sync {
            log.sync().map_err(|e| self.log_failed(e))?;
        }
        Ok(())
    }

    /// One synced commit of `edits` that also covers every log record so
    /// far; the caller then starts the log again.
    fn checkpoint(&self, log: &log::Log, edits: &[Edit]) -> Result<(), DiskError> {
        let mut tx = self.db.begin_write().map_err(|e| self.failed(e))?;
        tx.set_durability(Durability::Immediate)
            .map_err(|e| self.failed(e))?;
        edit::apply(&tx, edits).map_err(|e| self.failed(e))?;
        edit::apply(&tx, &[Edit::Meta(LOG_SEQ.into(), log.last_seq())])
            .map_err(|e| self.failed(e))?;
        tx.commit().map_err(|e| self.failed(e))
    }

    fn log_failed(&self, e: std::io::Error) -> DiskError {
        DiskError::Store {
            path: self.path.with_file_name(LOG_NAME),
            detail: e.to_string(),
        }
    }

    /// Pushes earlier [`Flush::Later`] writes to the disk.
    pub fn sync(&self) -> Result<(), DiskError> {
        let log = self.log.lock().unwrap_or_else(PoisonError::into_inner);
        log.sync().map_err(|e| self.log_failed(e))
    }

    /// Writes what `changes` names as `store` holds it now.
    pub fn write(
        &self,
        store: &mut Store,
        changes: &Changes,
        flush: Flush,
    ) -> Result<(), DiskError> {
        let edits = edits(store, changes);
        self.commit(&edits, flush)?;
        for name in &changes.vars {
            if let Some(var) = store.vars.get_mut(name) {
                var.stored_seq = var.seq;
            }
        }
        Ok(())
    }

    fn damaged(
        &self,
        table: &'static str,
        key: impl std::fmt::Display,
        e: impl std::fmt::Display,
    ) -> DiskError {
        DiskError::Damaged {
            path: self.path.clone(),
            table,
            key: key.to_string(),
            detail: e.to_string(),
        }
    }

    fn name(&self, table: &'static str, key: &str) -> Result<Name, DiskError> {
        Name::new(key).map_err(|e| self.damaged(table, key, e))
    }

    /// Loads the state into `store` (empty, tracking changes or not). A
    /// queued place is kept `places_for` after the load for its client to
    /// ask again; grants and held units get the store's usual grace.
    pub fn load(&self, store: &mut Store, places_for: Duration) -> Result<(), DiskError> {
        let now = Instant::now();
        let wall = unix_ms(SystemTime::now());
        let fail = |e: redb::Error| self.failed(e);
        let tx = self.db.begin_read().map_err(|e| fail(e.into()))?;
        let vars = tx.open_table(VARS).map_err(|e| fail(e.into()))?;
        let values = tx.open_table(VALUES).map_err(|e| fail(e.into()))?;
        for entry in vars.iter().map_err(|e| fail(e.into()))? {
            let (k, v) = entry.map_err(|e| fail(e.into()))?;
            let key = k.value();
            let name = self.name("vars", key)?;
            let record: VarRecord =
                serde_json::from_slice(v.value()).map_err(|e| self.damaged("vars", key, e))?;
            let mut var = Var::new(record.len.max(1));
            var.seq = record.seq;
            var.stored_seq = record.seq;
            for entry in values
                .range((key, 0)..=(key, u64::MAX))
                .map_err(|e| fail(e.into()))?
            {
                let (k, v) = entry.map_err(|e| fail(e.into()))?;
                let (_, seq) = k.value();
                let value: serde_json::Value = serde_json::from_slice(v.value())
                    .map_err(|e| self.damaged("values", format!("{key}#{seq}"), e))?;
                var.sizes.push_back(v.value().len() as u64);
                var.values.push_back(value);
            }
            // A history must end at `seq` with consecutive numbers; keep the
            // newest `len` should the file hold more.
            var.trim();
            store.bytes += var.sizes.iter().sum::<u64>();
            store.vars.insert(name, var);
        }
        let sems = tx.open_table(SEMS).map_err(|e| fail(e.into()))?;
        for entry in sems.iter().map_err(|e| fail(e.into()))? {
            let (k, v) = entry.map_err(|e| fail(e.into()))?;
            let name = self.name("sems", k.value())?;
            let record: SemRecord = serde_json::from_slice(v.value())
                .map_err(|e| self.damaged("sems", k.value(), e))?;
            store.sems.insert(
                name,
                Sem {
                    value: record.value,
                    queue: record.queue.into(),
                },
            );
        }
        let tickets = tx.open_table(TICKETS).map_err(|e| fail(e.into()))?;
        for entry in tickets.iter().map_err(|e| fail(e.into()))? {
            let (k, v) = entry.map_err(|e| fail(e.into()))?;
            let record: TicketRecord = serde_json::from_slice(v.value())
                .map_err(|e| self.damaged("tickets", k.value(), e))?;
            let sem = self.name("tickets", &record.sem)?;
            store.tickets.insert(
                k.value().to_string(),
                Ticket {
                    sem,
                    owner: record.owner,
                    state: if record.granted {
                        TicketState::Granted { at: now }
                    } else {
                        TicketState::Queued {
                            lapse_at: Some(now + places_for),
                        }
                    },
                    undo: record.undo,
                    units: record.units.max(1),
                },
            );
        }
        let held = tx.open_table(HELD).map_err(|e| fail(e.into()))?;
        for entry in held.iter().map_err(|e| fail(e.into()))? {
            let (k, v) = entry.map_err(|e| fail(e.into()))?;
            let (sem, owner) = k.value();
            let sem = self.name("held", sem)?;
            store.held.insert(
                (sem, owner.to_string()),
                Held {
                    units: v.value(),
                    since: now,
                },
            );
        }
        let ops = tx.open_table(OPS).map_err(|e| fail(e.into()))?;
        let mut remembered = Vec::new();
        for entry in ops.iter().map_err(|e| fail(e.into()))? {
            let (k, v) = entry.map_err(|e| fail(e.into()))?;
            let record: OpRecord =
                serde_json::from_slice(v.value()).map_err(|e| self.damaged("ops", k.value(), e))?;
            let age = Duration::from_millis(wall.saturating_sub(record.at_ms));
            let at = now.checked_sub(age).unwrap_or(now);
            remembered.push((at, k.value().to_string(), record.reply));
        }
        remembered.sort_by_key(|(at, _, _)| *at);
        for (at, op, reply) in remembered {
            store.remembered.insert(op.clone(), reply);
            store.remembered_order.push_back((at, op));
        }
        let meta = tx.open_table(META).map_err(|e| fail(e.into()))?;
        if let Some(n) = meta.get(NEXT_ANONYMOUS).map_err(|e| fail(e.into()))? {
            store.next_anonymous = n.value();
        }
        Ok(())
    }
}

fn json<T: Serialize>(value: &T) -> Vec<u8> {
    serde_json::to_vec(value).unwrap_or_default()
}

/// What `changes` names, as `store` holds it now.
fn edits(store: &Store, changes: &Changes) -> Vec<Edit> {
    let now = Instant::now();
    let wall = unix_ms(SystemTime::now());
    let mut out = Vec::new();
    for name in &changes.vars {
        let key = name.to_string();
        let Some(var) = store.vars.get(name) else {
            out.push(Edit::Var(key.clone(), None));
            out.push(Edit::DropValues(key, None));
            continue;
        };
        let record = VarRecord {
            len: var.len,
            seq: var.seq,
        };
        out.push(Edit::Var(key.clone(), Some(json(&record))));
        let first = var.first_seq();
        // Values dropped by a trim or a delete go; new ones come.
        out.push(Edit::DropValues(key.clone(), Some(first)));
        for (i, value) in var.values.iter().enumerate() {
            let seq = first + i as u64;
            if seq > var.stored_seq {
                out.push(Edit::Value(key.clone(), seq, json(value)));
            }
        }
    }
    for name in &changes.sems {
        let record = store.sems.get(name).map(|sem| SemRecord {
            value: sem.value,
            queue: sem.queue.iter().cloned().collect(),
        });
        out.push(Edit::Sem(name.to_string(), record.map(|r| json(&r))));
    }
    for id in &changes.tickets {
        let record = store.tickets.get(id).map(|t| TicketRecord {
            sem: t.sem.to_string(),
            owner: t.owner.clone(),
            granted: matches!(t.state, TicketState::Granted { .. }),
            undo: t.undo,
            units: t.units,
        });
        out.push(Edit::Ticket(id.clone(), record.map(|r| json(&r))));
    }
    for key in &changes.held {
        let units = store.held.get(key).map(|h| h.units);
        out.push(Edit::Held(key.0.to_string(), key.1.clone(), units));
    }
    for op in &changes.ops {
        let record = store.remembered.get(op).map(|reply| {
            // How long ago it was remembered, carried as a wall time.
            let age = store
                .remembered_order
                .iter()
                .rev()
                .find(|(_, o)| o == op)
                .map_or(Duration::ZERO, |(at, _)| now.saturating_duration_since(*at));
            OpRecord {
                at_ms: wall.saturating_sub(age.as_millis() as u64),
                reply: reply.clone(),
            }
        });
        out.push(Edit::Op(op.clone(), record.map(|r| json(&r))));
    }
    if changes.counter {
        out.push(Edit::Meta(NEXT_ANONYMOUS.into(), store.next_anonymous));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;
    use std::sync::atomic::{AtomicU64, Ordering};

    fn n(s: &str) -> Name {
        Name::new(s).unwrap()
    }

    fn scratch() -> PathBuf {
        static NEXT: AtomicU64 = AtomicU64::new(0);
        let dir = std::env::temp_dir().join(format!(
            "rome-durable-{}-{}",
            std::process::id(),
            NEXT.fetch_add(1, Ordering::Relaxed)
        ));
        let _ = std::fs::remove_dir_all(&dir);
        dir
    }

    /// Everything a client can observe of a store, times left out.
    fn observe(s: &Store) -> String {
        let mut out = String::new();
        for (name, var) in &s.vars {
            out += &format!(
                "var {name} len={} seq={} {:?}\n",
                var.len, var.seq, var.values
            );
        }
        for (name, sem) in &s.sems {
            out += &format!("sem {name} value={} queue={:?}\n", sem.value, sem.queue);
        }
        let mut tickets: Vec<_> = s.tickets.iter().collect();
        tickets.sort_by_key(|(id, _)| id.as_str());
        for (id, t) in tickets {
            let granted = matches!(t.state, TicketState::Granted { .. });
            out += &format!(
                "ticket {id} {} {:?} granted={granted} undo={} units={}\n",
                t.sem, t.owner, t.undo, t.units
            );
        }
        for ((sem, owner), h) in &s.held {
            out += &format!("held {sem} {owner} {}\n", h.units);
        }
        let mut ops: Vec<_> = s.remembered.iter().collect();
        ops.sort_by_key(|(id, _)| id.as_str());
        for (op, reply) in ops {
            out += &format!("op {op} {reply:?}\n");
        }
        out += &format!("anon {} bytes {}\n", s.next_anonymous, s.bytes);
        out
    }

    fn reload(dir: &Path) -> Store {
        let disk = Disk::open(dir).unwrap();
        let mut s = Store::new(4).track_changes();
        disk.load(&mut s, Duration::from_secs(5)).unwrap();
        s
    }

    /// A small deterministic generator, so a failure is reproducible.
    struct Lcg(u64);
    impl Lcg {
        fn next(&mut self, below: u64) -> u64 {
            self.0 = self
                .0
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (self.0 >> 33) % below
        }
    }

    #[test]
    fn every_change_written_is_loaded_back_the_same() {
        let dir = scratch();
        let mut disk = Disk::open(&dir).unwrap();
        let mut s = Store::new(4).track_changes();
        let mut rng = Lcg(7);
        let now = Instant::now();
        let vars = ["a", "b", "c"];
        let sems = ["s", "t"];
        let owners = ["o1", "o2", "o3"];
        for step in 0..3000u64 {
            let var = n(vars[rng.next(3) as usize]);
            let sem = n(sems[rng.next(2) as usize]);
            let owner = owners[rng.next(3) as usize];
            let ticket = format!("{owner}-{}", rng.next(6));
            let op = format!("op-{step}");
            let _ = match rng.next(14) {
                0..=2 => s
                    .set(&var, json!({"step": step}), Some(&op), now)
                    .map(|_| ()),
                3 => s.put(&var, json!(step)).map(|_| ()),
                4 => {
                    s.delete(&var);
                    Ok(())
                }
                5 => s.history(&var, Some(1 + rng.next(5) as u32)).map(|_| ()),
                6 => s.create(&sem, rng.next(2)).map(|_| ()),
                7 => s.signal(&sem, Some(&op), now).map(|_| ()),
                8 => s.try_wait(&sem, Some(&op), now).map(|_| ()),
                // Tickets numbered 0 wait for two units at once.
                9 => s
                    .wait_units(
                        &sem,
                        Some(&ticket),
                        Some(owner),
                        rng.next(2) == 0,
                        1 + u64::from(ticket.ends_with("-0")),
                        now,
                    )
                    .map(|_| ()),
                10 => s.wait(&sem, None, None, now).map(|_| ()),
                11 => s.ack(&sem, &ticket, now).map(|_| ()),
                12 => s.cancel(&sem, &ticket).map(|_| ()),
                _ => {
                    s.owner_gone(owner, now);
                    Ok(())
                }
            };
            let changes = s.take_changes();
            disk.write(&mut s, &changes, Flush::Later).unwrap();
            if step % 500 == 499 {
                // A restart: what is on disk is what was in memory.
                drop(disk);
                let back = reload(&dir);
                assert_eq!(observe(&back), observe(&s), "after step {step}");
                disk = Disk::open(&dir).unwrap();
            }
        }
        assert!(s.histories().count() == 3 && s.semaphores().count() == 2);
        // The loaded store carries on: its own changes are kept too.
        drop(disk);
        let mut back = reload(&dir);
        back.set(&n("after"), json!(1), Some("after-op"), now)
            .unwrap();
        back.signal(&n("s"), None, now).unwrap();
        let changes = back.take_changes();
        let disk = Disk::open(&dir).unwrap();
        disk.write(&mut back, &changes, Flush::Sync).unwrap();
        drop(disk);
        let again = reload(&dir);
        assert_eq!(observe(&again), observe(&back));
        assert_ne!(observe(&again), observe(&s));
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn a_retried_request_after_a_restart_is_answered_from_memory() {
        let dir = scratch();
        let disk = Disk::open(&dir).unwrap();
        let mut s = Store::new(4).track_changes();
        let t = Instant::now();
        s.create(&n("s"), 0).unwrap();
        let first = s.set(&n("v"), json!(1), Some("c-1"), t).unwrap();
        s.signal(&n("s"), Some("c-2"), t).unwrap();
        let changes = s.take_changes();
        disk.write(&mut s, &changes, Flush::Sync).unwrap();
        drop(disk);
        let mut back = reload(&dir);
        let again = back.set(&n("v"), json!(1), Some("c-1"), t).unwrap();
        assert_eq!(again.reply, first.reply);
        assert!(
            again.commit.is_none(),
            "the retried set was committed twice"
        );
        back.signal(&n("s"), Some("c-2"), t).unwrap();
        assert_eq!(
            back.semaphore(&n("s")).unwrap().value,
            1,
            "the retried signal counted twice"
        );
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn a_second_server_on_the_same_directory_is_refused_by_name() {
        let dir = scratch();
        let _first = Disk::open(&dir).unwrap();
        let e = Disk::open(&dir).unwrap_err();
        assert!(matches!(e, DiskError::InUse { .. }), "{e}");
        assert!(e.to_string().contains("--data-dir"), "{e}");
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn a_damaged_record_is_named_not_skipped() {
        let dir = scratch();
        let disk = Disk::open(&dir).unwrap();
        let broken = Edit::Sem("broken".into(), Some(b"{not json".to_vec()));
        disk.commit(&[broken], Flush::Sync).unwrap();
        let mut s = Store::new(4);
        let e = disk.load(&mut s, Duration::from_secs(1)).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("'broken'") && text.contains("sems"), "{text}");
        let _ = std::fs::remove_dir_all(dir);
    }

    /// A copy of the directory's files as they are now on disk: what a
    /// crash at this moment would leave.
    fn crash_copy(dir: &Path, log: bool) -> PathBuf {
        let to = scratch();
        std::fs::create_dir_all(&to).unwrap();
        std::fs::copy(dir.join(FILE_NAME), to.join(FILE_NAME)).unwrap();
        if log {
            std::fs::copy(dir.join(LOG_NAME), to.join(LOG_NAME)).unwrap();
        }
        to
    }

    /// What a store loaded after a crash at this moment holds, with its
    /// log or without it.
    fn after_a_crash(dir: &Path, log: bool) -> String {
        let copy = crash_copy(dir, log);
        let seen = observe(&reload(&copy));
        let _ = std::fs::remove_dir_all(copy);
        seen
    }

    #[test]
    fn a_crash_keeps_every_synced_write_through_the_log_and_its_checkpoints() {
        let dir = scratch();
        let disk = Disk::open(&dir).unwrap();
        let mut s = Store::new(4).track_changes();
        let now = Instant::now();
        let big = "x".repeat(100_000);
        // Some 12 MB of values: the 8 MiB log fills and is checkpointed.
        for step in 0..120u64 {
            s.set(&n("big"), json!({"step": step, "pad": big}), None, now)
                .unwrap();
            s.create(&n("s"), 0).unwrap();
            s.signal(&n("s"), Some(&format!("op-{step}")), now).unwrap();
            let changes = s.take_changes();
            disk.write(&mut s, &changes, Flush::Sync).unwrap();
            if step == 10 || step == 119 {
                assert_eq!(after_a_crash(&dir, true), observe(&s), "after step {step}");
                // Without its log the state file is behind: the log is
                // what kept the last writes.
                assert_ne!(after_a_crash(&dir, false), observe(&s), "after step {step}");
            }
        }
        drop(disk);
        assert_eq!(observe(&reload(&dir)), observe(&s));
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn a_crash_between_a_checkpoint_and_the_logs_new_round_loses_nothing() {
        let dir = scratch();
        let disk = Disk::open(&dir).unwrap();
        let mut s = Store::new(4).track_changes();
        let now = Instant::now();
        let write = |s: &mut Store, step: u64| {
            s.set(&n("v"), json!(step), Some(&format!("op-{step}")), now)
                .unwrap();
            let changes = s.take_changes();
            disk.write(s, &changes, Flush::Sync).unwrap();
        };
        for step in 0..5 {
            write(&mut s, step);
        }
        // The checkpoint is synced, but the log is not started again: its
        // records are all older than the state file's mark now.
        {
            let log = disk.log.lock().unwrap();
            disk.checkpoint(&log, &[]).unwrap();
        }
        assert_eq!(after_a_crash(&dir, true), observe(&s));
        // Writes go on after the old records; they are read back too.
        for step in 5..8 {
            write(&mut s, step);
        }
        assert_eq!(after_a_crash(&dir, true), observe(&s));
        let _ = std::fs::remove_dir_all(dir);
    }
}

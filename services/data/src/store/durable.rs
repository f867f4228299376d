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
//! ```
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

use redb::{Database, Durability, ReadableDatabase, ReadableTable, TableDefinition};

const VARS: TableDefinition<&str, &[u8]> = TableDefinition::new("vars");
const VALUES: TableDefinition<(&str, u64), &[u8]> = TableDefinition::new("values");
const SEMS: TableDefinition<&str, &[u8]> = TableDefinition::new("sems");
const TICKETS: TableDefinition<&str, &[u8]> = TableDefinition::new("tickets");
const HELD: TableDefinition<(&str, &str), u64> = TableDefinition::new("held");
const OPS: TableDefinition<&str, &[u8]> = TableDefinition::new("ops");
const META: TableDefinition<&str, u64> = TableDefinition::new("meta");
const NEXT_ANONYMOUS: &str = "next_anonymous";

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

/// The open state file of one data server.
pub struct Disk {
    db: Database,
    path: PathBuf,
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
        let disk = Disk { db, path };
        // Every table exists from the start, so reads need no special case.
        disk.write_with(Flush::Sync, |tx| {
            tx.open_table(VARS)?;
            tx.open_table(VALUES)?;
            tx.open_table(SEMS)?;
            tx.open_table(TICKETS)?;
            tx.open_table(HELD)?;
            tx.open_table(OPS)?;
            tx.open_table(META)?;
            Ok(())
        })?;
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

    fn write_with(
        &self,
        flush: Flush,
        f: impl FnOnce(&redb::WriteTransaction) -> Result<(), redb::Error>,
    ) -> Result<(), DiskError> {
        let mut tx = self.db.begin_write().map_err(|e| self.failed(e))?;
        tx.set_durability(match flush {
            Flush::Sync => Durability::Immediate,
            Flush::Later => Durability::None,
        })
        .map_err(|e| self.failed(e))?;
        f(&tx).map_err(|e| self.failed(e))?;
        tx.commit().map_err(|e| self.failed(e))
    }

    /// Pushes earlier [`Flush::Later`] writes to the disk.
    pub fn sync(&self) -> Result<(), DiskError> {
        self.write_with(Flush::Sync, |_| Ok(()))
    }

    /// Writes what `changes` names as `store` holds it now.
    pub fn write(
        &self,
        store: &mut Store,
        changes: &Changes,
        flush: Flush,
    ) -> Result<(), DiskError> {
        let now = Instant::now();
        let wall = unix_ms(SystemTime::now());
        self.write_with(flush, |tx| {
            let mut vars = tx.open_table(VARS)?;
            let mut values = tx.open_table(VALUES)?;
            for name in &changes.vars {
                let Some(var) = store.vars.get(name) else {
                    vars.remove(name.as_str())?;
                    values
                        .retain_in((name.as_str(), 0)..=(name.as_str(), u64::MAX), |_, _| false)?;
                    continue;
                };
                let record = VarRecord {
                    len: var.len,
                    seq: var.seq,
                };
                vars.insert(
                    name.as_str(),
                    serde_json::to_vec(&record).unwrap_or_default().as_slice(),
                )?;
                let first = var.first_seq();
                // Values dropped by a trim or a delete go; new ones come.
                values.retain_in((name.as_str(), 0)..(name.as_str(), first), |_, _| false)?;
                for (i, value) in var.values.iter().enumerate() {
                    let seq = first + i as u64;
                    if seq > var.stored_seq {
                        let bytes = serde_json::to_vec(value).unwrap_or_default();
                        values.insert((name.as_str(), seq), bytes.as_slice())?;
                    }
                }
            }
            let mut sems = tx.open_table(SEMS)?;
            for name in &changes.sems {
                match store.sems.get(name) {
                    Some(sem) => {
                        let record = SemRecord {
                            value: sem.value,
                            queue: sem.queue.iter().cloned().collect(),
                        };
                        sems.insert(
                            name.as_str(),
                            serde_json::to_vec(&record).unwrap_or_default().as_slice(),
                        )?;
                    }
                    None => {
                        sems.remove(name.as_str())?;
                    }
                }
            }
            let mut tickets = tx.open_table(TICKETS)?;
            for id in &changes.tickets {
                match store.tickets.get(id) {
                    Some(t) => {
                        let record = TicketRecord {
                            sem: t.sem.to_string(),
                            owner: t.owner.clone(),
                            granted: matches!(t.state, TicketState::Granted { .. }),
                            undo: t.undo,
                        };
                        tickets.insert(
                            id.as_str(),
                            serde_json::to_vec(&record).unwrap_or_default().as_slice(),
                        )?;
                    }
                    None => {
                        tickets.remove(id.as_str())?;
                    }
                }
            }
            let mut held = tx.open_table(HELD)?;
            for key in &changes.held {
                match store.held.get(key) {
                    Some(h) => {
                        held.insert((key.0.as_str(), key.1.as_str()), h.units)?;
                    }
                    None => {
                        held.remove((key.0.as_str(), key.1.as_str()))?;
                    }
                }
            }
            let mut ops = tx.open_table(OPS)?;
            for op in &changes.ops {
                match store.remembered.get(op) {
                    Some(reply) => {
                        // How long ago it was remembered, carried as a wall time.
                        let age = store
                            .remembered_order
                            .iter()
                            .rev()
                            .find(|(_, o)| o == op)
                            .map_or(Duration::ZERO, |(at, _)| now.saturating_duration_since(*at));
                        let record = OpRecord {
                            at_ms: wall.saturating_sub(age.as_millis() as u64),
                            reply: reply.clone(),
                        };
                        ops.insert(
                            op.as_str(),
                            serde_json::to_vec(&record).unwrap_or_default().as_slice(),
                        )?;
                    }
                    None => {
                        ops.remove(op.as_str())?;
                    }
                }
            }
            if changes.counter {
                tx.open_table(META)?
                    .insert(NEXT_ANONYMOUS, store.next_anonymous)?;
            }
            Ok(())
        })?;
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
                "ticket {id} {} {:?} granted={granted} undo={}\n",
                t.sem, t.owner, t.undo
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
                9 => s
                    .wait_undo(&sem, Some(&ticket), Some(owner), rng.next(2) == 0, now)
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
        disk.write_with(Flush::Sync, |tx| {
            tx.open_table(SEMS)?
                .insert("broken", b"{not json".as_slice())?;
            Ok(())
        })
        .unwrap();
        let mut s = Store::new(4);
        let e = disk.load(&mut s, Duration::from_secs(1)).unwrap_err();
        let text = e.to_string();
        assert!(text.contains("'broken'") && text.contains("sems"), "{text}");
        let _ = std::fs::remove_dir_all(dir);
    }
}

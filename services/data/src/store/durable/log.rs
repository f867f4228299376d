//! The write-ahead log beside the state file, `DIR/data.log`.
//!
//! Syncing a redb transaction writes and flushes a page of every table it
//! touched; appending one record to a file whose blocks already exist
//! and syncing its data is a single small write, about half the time
//! here. So every write is committed to redb without a sync and appended
//! here as a record, and a request is answered once the log is synced.
//! When the log is full, one synced redb commit (a checkpoint) covers
//! everything so far, and the log starts again from its beginning.
//!
//! The file is made its full size, written with zeros and synced when it
//! is created, so that a later sync has no size or block map to change.
//!
//! A record (little-endian):
//!
//! ```text
//! len:u32  crc:u32  seq:u64  payload (len bytes)
//! ```
//!
//! `crc` is the CRC-32 of `seq` and the payload. Numbers run on from one
//! record to the next, across checkpoints; the state file keeps the number
//! of the last record it covers. On opening, the records after it are read
//! from the file's beginning for as long as each is whole (its CRC) and
//! has the next number. A record torn by a crash was never answered, and
//! the older records a new round leaves behind have lower numbers, so
//! reading stops at whichever comes first.

use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::os::unix::fs::FileExt;
use std::path::Path;

/// The log's file name inside a data directory.
pub const LOG_NAME: &str = "data.log";

/// The log's size: some twenty thousand plain sets between checkpoints.
const LOG_BYTES: u64 = 8 << 20;

const HEAD: usize = 16;

/// A record read back: its number and payload.
pub(super) type Record = (u64, Vec<u8>);

/// The open log.
#[derive(Debug)]
pub(super) struct Log {
    file: File,
    /// Where the next record goes.
    end: u64,
    /// The next record's number.
    next_seq: u64,
    /// Whether the file has its full size, written (see the module).
    sized: bool,
    /// The directory, synced once the file is made.
    dir: Option<std::path::PathBuf>,
}

impl Log {
    /// Opens (or creates) the log at `path` and reads the records after
    /// number `after` (the last the state file covers), in order. Nothing
    /// is written until [`Log::restart`], which the caller calls once the
    /// state file has these records.
    pub(super) fn open(path: &Path, after: u64) -> io::Result<(Log, Vec<Record>)> {
        let mut file = OpenOptions::new()
            .read(true)
            .write(true)
            .create(true)
            .truncate(false)
            .open(path)?;
        let mut bytes = Vec::new();
        file.read_to_end(&mut bytes)?;
        let records = records_after(&bytes, after);
        let next_seq = records.last().map_or(after, |(seq, _)| *seq) + 1;
        let log = Log {
            file,
            end: 0,
            next_seq,
            sized: bytes.len() as u64 == LOG_BYTES,
            dir: path.parent().map(Path::to_path_buf),
        };
        Ok((log, records))
    }

    /// The number of the last record appended (or read at opening).
    pub(super) fn last_seq(&self) -> u64 {
        self.next_seq - 1
    }

    /// Whether a record of `payload` bytes fits before the end.
    pub(super) fn fits(&self, payload: usize) -> bool {
        self.end + (HEAD + payload) as u64 <= LOG_BYTES
    }

    /// Appends a record (not synced); the caller has checked it
    /// [`fits`](Log::fits).
    pub(super) fn append(&mut self, payload: &[u8]) -> io::Result<()> {
        let seq = self.next_seq;
        let mut record = Vec::with_capacity(HEAD + payload.len());
        record.extend_from_slice(&(payload.len() as u32).to_le_bytes());
        record.extend_from_slice(&crc(seq, payload).to_le_bytes());
        record.extend_from_slice(&seq.to_le_bytes());
        record.extend_from_slice(payload);
        // On failure neither moves: the next append writes over it.
        self.file.write_all_at(&record, self.end)?;
        self.end += record.len() as u64;
        self.next_seq += 1;
        Ok(())
    }

    /// Puts what was appended on disk.
    pub(super) fn sync(&self) -> io::Result<()> {
        self.file.sync_data()
    }

    /// Starts again from the beginning, after a checkpoint that covers
    /// every record so far. A new log (or one of another size) is made its
    /// full size first.
    pub(super) fn restart(&mut self) -> io::Result<()> {
        if !self.sized {
            self.file.set_len(0)?;
            self.file.write_all_at(&vec![0; LOG_BYTES as usize], 0)?;
            self.file.sync_all()?;
            // The file's name is on disk too.
            if let Some(dir) = &self.dir {
                File::open(dir)?.sync_all()?;
            }
            self.sized = true;
        }
        self.end = 0;
        Ok(())
    }
}

fn crc(seq: u64, payload: &[u8]) -> u32 {
    let mut h = crc32fast::Hasher::new();
    h.update(&seq.to_le_bytes());
    h.update(payload);
    h.finalize()
}

/// The whole records with consecutive numbers from the start of `bytes`
/// (the newest round: a new round starts at the beginning), those
/// numbered after `after`.
fn records_after(bytes: &[u8], after: u64) -> Vec<Record> {
    let mut out = Vec::new();
    let mut at = 0usize;
    let mut want = None;
    while let Some(head) = bytes.get(at..at + HEAD) {
        let len = u32::from_le_bytes([head[0], head[1], head[2], head[3]]) as usize;
        let sum = u32::from_le_bytes([head[4], head[5], head[6], head[7]]);
        let seq = u64::from_le_bytes(head[8..16].try_into().unwrap_or_default());
        let Some(payload) = bytes.get(at + HEAD..at + HEAD + len) else {
            break;
        };
        if want.is_some_and(|w| seq != w) || crc(seq, payload) != sum {
            break;
        }
        if seq > after {
            out.push((seq, payload.to_vec()));
        }
        at += HEAD + len;
        want = Some(seq + 1);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scratch(name: &str) -> std::path::PathBuf {
        let dir = std::env::temp_dir().join(format!("rome-log-{}-{name}", std::process::id()));
        let _ = std::fs::remove_dir_all(&dir);
        std::fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn records_read_back_in_order_after_the_one_named() {
        let dir = scratch("order");
        let path = dir.join(LOG_NAME);
        let (mut log, none) = Log::open(&path, 0).unwrap();
        assert!(none.is_empty());
        log.restart().unwrap();
        assert_eq!(std::fs::metadata(&path).unwrap().len(), LOG_BYTES);
        for p in [&b"one"[..], b"", b"three"] {
            log.append(p).unwrap();
        }
        log.sync().unwrap();
        drop(log);
        let (log, read) = Log::open(&path, 0).unwrap();
        assert_eq!(
            read,
            vec![
                (1, b"one".to_vec()),
                (2, Vec::new()),
                (3, b"three".to_vec())
            ]
        );
        assert_eq!(log.last_seq(), 3);
        // The state file covers the first two: only the third is read.
        let (_, read) = Log::open(&path, 2).unwrap();
        assert_eq!(read, vec![(3, b"three".to_vec())]);
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn a_new_round_stops_at_the_old_rounds_records_and_a_torn_one() {
        let dir = scratch("round");
        let path = dir.join(LOG_NAME);
        let (mut log, _) = Log::open(&path, 0).unwrap();
        log.restart().unwrap();
        for i in 0..10u8 {
            log.append(&[i; 40]).unwrap();
        }
        // A checkpoint covers 1..=10; the next round writes over the start.
        log.restart().unwrap();
        log.append(b"eleven").unwrap();
        log.append(b"twelve").unwrap();
        drop(log);
        let (_, read) = Log::open(&path, 10).unwrap();
        assert_eq!(
            read,
            vec![(11, b"eleven".to_vec()), (12, b"twelve".to_vec())]
        );
        // The second record torn (its last byte never written): only the first.
        let bytes = std::fs::read(&path).unwrap();
        let second_end = 2 * HEAD + 6 + 6;
        let file = OpenOptions::new().write(true).open(&path).unwrap();
        file.write_all_at(&[bytes[second_end - 1] ^ 0xff], (second_end - 1) as u64)
            .unwrap();
        let (log, read) = Log::open(&path, 10).unwrap();
        assert_eq!(read, vec![(11, b"eleven".to_vec())]);
        assert_eq!(log.last_seq(), 11);
        let _ = std::fs::remove_dir_all(dir);
    }

    #[test]
    fn a_record_that_does_not_fit_is_told_before_it_is_written() {
        let dir = scratch("fit");
        let (mut log, _) = Log::open(&dir.join(LOG_NAME), 0).unwrap();
        log.restart().unwrap();
        assert!(log.fits(LOG_BYTES as usize - HEAD));
        assert!(!log.fits(LOG_BYTES as usize - HEAD + 1));
        log.append(&[1]).unwrap();
        assert!(!log.fits(LOG_BYTES as usize - HEAD));
        log.restart().unwrap();
        assert!(log.fits(LOG_BYTES as usize - HEAD));
        let _ = std::fs::remove_dir_all(dir);
    }
}

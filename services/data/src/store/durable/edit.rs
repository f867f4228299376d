//! One write's changes to the state file as a list of edits: applied to a
//! redb transaction, and encoded for the write-ahead log so that a write
//! the file has not yet synced can be applied again after a crash.
//!
//! Each edit says what a key holds now (or that it is gone), never how it
//! changed, so applying a log record twice, or on top of a state that
//! already has it, leaves the same state.
//!
//! Encoding (little-endian; a string is a u32 length and its UTF-8 bytes,
//! bytes likewise; an option is a byte 0 or 1 and then the value):
//!
//! ```text
//! 1 var     name  option<bytes>
//! 2 value   name  seq:u64  bytes
//! 3 drop    name  option<below:u64>     values of name (below seq, or all)
//! 4 sem     name  option<bytes>
//! 5 ticket  id    option<bytes>
//! 6 held    sem   owner  option<units:u64>
//! 7 op      id    option<bytes>
//! 8 meta    key   u64
//! ```

use redb::{TableDefinition, WriteTransaction};

pub(super) const VARS: TableDefinition<&str, &[u8]> = TableDefinition::new("vars");
pub(super) const VALUES: TableDefinition<(&str, u64), &[u8]> = TableDefinition::new("values");
pub(super) const SEMS: TableDefinition<&str, &[u8]> = TableDefinition::new("sems");
pub(super) const TICKETS: TableDefinition<&str, &[u8]> = TableDefinition::new("tickets");
pub(super) const HELD: TableDefinition<(&str, &str), u64> = TableDefinition::new("held");
pub(super) const OPS: TableDefinition<&str, &[u8]> = TableDefinition::new("ops");
pub(super) const META: TableDefinition<&str, u64> = TableDefinition::new("meta");

/// One key of one table, as it is now.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) enum Edit {
    /// `vars`: the record, or removed.
    Var(String, Option<Vec<u8>>),
    /// `values`: the value committed as number `seq`.
    Value(String, u64, Vec<u8>),
    /// `values`: every value of the name below `seq`, or all of them.
    DropValues(String, Option<u64>),
    /// `sems`: the record, or removed.
    Sem(String, Option<Vec<u8>>),
    /// `tickets`: the record, or removed.
    Ticket(String, Option<Vec<u8>>),
    /// `held`: the units a (semaphore, owner) holds, or removed.
    Held(String, String, Option<u64>),
    /// `ops`: the remembered reply, or forgotten.
    Op(String, Option<Vec<u8>>),
    /// `meta`: a counter.
    Meta(String, u64),
}

/// Applies `edits` in order to `tx`.
pub(super) fn apply(tx: &WriteTransaction, edits: &[Edit]) -> Result<(), redb::Error> {
    let mut vars = tx.open_table(VARS)?;
    let mut values = tx.open_table(VALUES)?;
    let mut sems = tx.open_table(SEMS)?;
    let mut tickets = tx.open_table(TICKETS)?;
    let mut held = tx.open_table(HELD)?;
    let mut ops = tx.open_table(OPS)?;
    let mut meta = tx.open_table(META)?;
    for edit in edits {
        match edit {
            Edit::Var(name, Some(record)) => drop(vars.insert(name.as_str(), record.as_slice())?),
            Edit::Var(name, None) => drop(vars.remove(name.as_str())?),
            Edit::Value(name, seq, bytes) => {
                drop(values.insert((name.as_str(), *seq), bytes.as_slice())?)
            }
            Edit::DropValues(name, Some(below)) => {
                values.retain_in((name.as_str(), 0)..(name.as_str(), *below), |_, _| false)?
            }
            Edit::DropValues(name, None) => {
                values.retain_in((name.as_str(), 0)..=(name.as_str(), u64::MAX), |_, _| false)?
            }
            Edit::Sem(name, Some(record)) => drop(sems.insert(name.as_str(), record.as_slice())?),
            Edit::Sem(name, None) => drop(sems.remove(name.as_str())?),
            Edit::Ticket(id, Some(record)) => drop(tickets.insert(id.as_str(), record.as_slice())?),
            Edit::Ticket(id, None) => drop(tickets.remove(id.as_str())?),
            Edit::Held(sem, owner, Some(units)) => {
                drop(held.insert((sem.as_str(), owner.as_str()), *units)?)
            }
            Edit::Held(sem, owner, None) => drop(held.remove((sem.as_str(), owner.as_str()))?),
            Edit::Op(id, Some(record)) => drop(ops.insert(id.as_str(), record.as_slice())?),
            Edit::Op(id, None) => drop(ops.remove(id.as_str())?),
            Edit::Meta(key, value) => drop(meta.insert(key.as_str(), *value)?),
        }
    }
    Ok(())
}

/// The log record of `edits`.
pub(super) fn encode(edits: &[Edit]) -> Vec<u8> {
    let mut out = Vec::new();
    for edit in edits {
        match edit {
            Edit::Var(name, record) => tagged(&mut out, 1, name, record),
            Edit::Value(name, seq, bytes) => {
                out.push(2);
                bytes_to(&mut out, name.as_bytes());
                out.extend_from_slice(&seq.to_le_bytes());
                bytes_to(&mut out, bytes);
            }
            Edit::DropValues(name, below) => {
                out.push(3);
                bytes_to(&mut out, name.as_bytes());
                u64_option_to(&mut out, *below);
            }
            Edit::Sem(name, record) => tagged(&mut out, 4, name, record),
            Edit::Ticket(id, record) => tagged(&mut out, 5, id, record),
            Edit::Held(sem, owner, units) => {
                out.push(6);
                bytes_to(&mut out, sem.as_bytes());
                bytes_to(&mut out, owner.as_bytes());
                u64_option_to(&mut out, *units);
            }
            Edit::Op(id, record) => tagged(&mut out, 7, id, record),
            Edit::Meta(key, value) => {
                out.push(8);
                bytes_to(&mut out, key.as_bytes());
                out.extend_from_slice(&value.to_le_bytes());
            }
        }
    }
    out
}

fn tagged(out: &mut Vec<u8>, tag: u8, key: &str, record: &Option<Vec<u8>>) {
    out.push(tag);
    bytes_to(out, key.as_bytes());
    match record {
        Some(bytes) => {
            out.push(1);
            bytes_to(out, bytes);
        }
        None => out.push(0),
    }
}

fn bytes_to(out: &mut Vec<u8>, bytes: &[u8]) {
    out.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(bytes);
}

fn u64_option_to(out: &mut Vec<u8>, value: Option<u64>) {
    match value {
        Some(v) => {
            out.push(1);
            out.extend_from_slice(&v.to_le_bytes());
        }
        None => out.push(0),
    }
}

/// The edits of a log record; what is wrong with it if it does not parse
/// to the end.
pub(super) fn decode(mut bytes: &[u8]) -> Result<Vec<Edit>, String> {
    let mut edits = Vec::new();
    while let Some((&tag, rest)) = bytes.split_first() {
        bytes = rest;
        let r = &mut bytes;
        edits.push(match tag {
            1 => Edit::Var(text(r)?, option_bytes(r)?),
            2 => Edit::Value(text(r)?, u64_of(r)?, raw(r)?.to_vec()),
            3 => Edit::DropValues(text(r)?, option_u64(r)?),
            4 => Edit::Sem(text(r)?, option_bytes(r)?),
            5 => Edit::Ticket(text(r)?, option_bytes(r)?),
            6 => Edit::Held(text(r)?, text(r)?, option_u64(r)?),
            7 => Edit::Op(text(r)?, option_bytes(r)?),
            8 => Edit::Meta(text(r)?, u64_of(r)?),
            other => return Err(format!("unknown edit {other}")),
        });
    }
    Ok(edits)
}

fn take<'a>(r: &mut &'a [u8], n: usize) -> Result<&'a [u8], String> {
    if r.len() < n {
        return Err(format!("{n} bytes wanted, {} left", r.len()));
    }
    let (head, rest) = r.split_at(n);
    *r = rest;
    Ok(head)
}

fn u64_of(r: &mut &[u8]) -> Result<u64, String> {
    let b = take(r, 8)?;
    Ok(u64::from_le_bytes(b.try_into().map_err(|_| "a short u64")?))
}

fn raw<'a>(r: &mut &'a [u8]) -> Result<&'a [u8], String> {
    let b = take(r, 4)?;
    let n = u32::from_le_bytes(b.try_into().map_err(|_| "a short length")?);
    take(r, n as usize)
}

fn text(r: &mut &[u8]) -> Result<String, String> {
    String::from_utf8(raw(r)?.to_vec()).map_err(|e| format!("a name that is not UTF-8: {e}"))
}

fn flag(r: &mut &[u8]) -> Result<bool, String> {
    match take(r, 1)?[0] {
        0 => Ok(false),
        1 => Ok(true),
        other => Err(format!("an option marked {other}")),
    }
}

fn option_bytes(r: &mut &[u8]) -> Result<Option<Vec<u8>>, String> {
    Ok(if flag(r)? {
        Some(raw(r)?.to_vec())
    } else {
        None
    })
}

fn option_u64(r: &mut &[u8]) -> Result<Option<u64>, String> {
    Ok(if flag(r)? { Some(u64_of(r)?) } else { None })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn every_kind() -> Vec<Edit> {
        vec![
            Edit::Var("a".into(), Some(b"{\"len\":2}".to_vec())),
            Edit::Var("b".into(), None),
            Edit::Value("a".into(), 7, b"[1,2]".to_vec()),
            Edit::DropValues("a".into(), Some(6)),
            Edit::DropValues("b".into(), None),
            Edit::Sem("s".into(), Some(b"{}".to_vec())),
            Edit::Sem("t".into(), None),
            Edit::Ticket("k".into(), Some(Vec::new())),
            Edit::Ticket("l".into(), None),
            Edit::Held("s".into(), "o".into(), Some(3)),
            Edit::Held("s".into(), "p".into(), None),
            Edit::Op("op-1".into(), Some(b"{}".to_vec())),
            Edit::Op("op-2".into(), None),
            Edit::Meta("next".into(), u64::MAX),
        ]
    }

    #[test]
    fn every_kind_of_edit_reads_back_as_written() {
        let edits = every_kind();
        assert_eq!(decode(&encode(&edits)).unwrap(), edits);
        assert_eq!(decode(&[]).unwrap(), Vec::new());
    }

    #[test]
    fn a_cut_or_unknown_record_is_refused_with_what_is_wrong() {
        let bytes = encode(&every_kind());
        for cut in 1..bytes.len() {
            // A record cut anywhere inside an edit does not parse quietly
            // as fewer edits: it is an error, or ends on an edit boundary.
            match decode(&bytes[..cut]) {
                Ok(edits) => assert_eq!(encode(&edits), bytes[..cut]),
                Err(e) => assert!(e.contains("wanted") || e.contains("short"), "{e}"),
            }
        }
        let e = decode(&[9]).unwrap_err();
        assert!(e.contains("unknown edit 9"), "{e}");
        let e = decode(&[1, 1, 0, 0, 0, b'a', 5]).unwrap_err();
        assert!(e.contains("option marked 5"), "{e}");
    }
}

use super::*;
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::ErrorCode;

fn parse(key: &str, params: &str, payload: Option<&[u8]>) -> Result<Request, ErrorReply> {
    Request::parse(&Root::default(), key, Params::parse(params), payload)
}

fn code(key: &str, params: &str, payload: Option<&[u8]>) -> (ErrorCode, String) {
    let e = parse(key, params, payload).unwrap_err();
    (e.code, e.message)
}

#[test]
fn bad_json_payload_is_named() {
    let (c, m) = code("rome/data/set/PosX", "", Some(b"{not json"));
    assert_eq!(c, ErrorCode::BadJson);
    assert!(m.contains("value of 'PosX'"), "{m}");
    let (c, m) = code("rome/data/set/PosX", "", None);
    assert_eq!(c, ErrorCode::BadJson);
    assert!(m.contains("empty"), "{m}");
}

#[test]
fn unknown_operation_and_watch_queries_are_refused() {
    let (c, m) = code("rome/data/frob/x", "", None);
    assert_eq!(c, ErrorCode::UnknownKey);
    assert!(m.contains("try-wait"), "{m}");
    let (c, m) = code("rome/data/watch/x", "", None);
    assert_eq!(c, ErrorCode::UnknownKey);
    assert!(m.contains("subscribe"), "{m}");
}

#[test]
fn negative_or_zero_history_is_out_of_range() {
    for len in ["-3", "0", "1000001"] {
        let (c, m) = code("rome/data/history/PosX", &format!("len={len}"), None);
        assert_eq!(c, ErrorCode::OutOfRange, "{len}");
        assert!(m.contains("'len'") && m.contains(len), "{m}");
    }
}

#[test]
fn wrong_types_are_named() {
    for (key, params, what) in [
        ("rome/data/history/PosX", "len=abc", "'len'"),
        ("rome/data/var/PosX", "back=two", "'back'"),
        ("rome/data/create/S", "value=1.5", "'value'"),
        ("rome/data/wait/S", "hold_ms=soon", "'hold_ms'"),
    ] {
        let (c, m) = code(key, params, None);
        assert_eq!(c, ErrorCode::WrongType, "{key}?{params}");
        assert!(m.contains(what), "{m}");
    }
}

#[test]
fn out_of_range_numbers_are_named() {
    for (key, params) in [
        ("rome/data/var/PosX", "back=-2"),
        ("rome/data/create/S", "value=-1"),
        ("rome/data/wait/S", "hold_ms=600001"),
    ] {
        let (c, _) = code(key, params, None);
        assert_eq!(c, ErrorCode::OutOfRange, "{key}?{params}");
    }
}

#[test]
fn unknown_and_missing_parameters_are_named() {
    let (c, m) = code("rome/data/var/PosX", "bak=2", None);
    assert_eq!(c, ErrorCode::BadParameter);
    assert!(m.contains("'bak'") && m.contains("back"), "{m}");
    let (c, m) = code("rome/data/create/S", "", None);
    assert_eq!(c, ErrorCode::BadParameter);
    assert!(m.contains("value=N"), "{m}");
    let (c, _) = code("rome/data/cancel/S", "", None);
    assert_eq!(c, ErrorCode::BadParameter);
    let (c, m) = code("rome/data/wait/S", "ticket=a b", None);
    assert_eq!(c, ErrorCode::BadParameter);
    assert!(m.contains("'ticket'"), "{m}");
    let (c, m) = code("rome/data/signal/S", "", Some(b"1"));
    assert_eq!(c, ErrorCode::BadParameter);
    assert!(m.contains("no payload"), "{m}");
}

#[test]
fn zenoh_reserved_parameters_are_passed_over() {
    assert!(parse("rome/data/var/PosX", "_anyke", None).is_ok());
}

#[test]
fn wait_is_held_or_answered() {
    let mut store = Store::new(4);
    let now = Instant::now();
    parse("rome/data/create/S", "value=1", None)
        .unwrap()
        .apply(&mut store, now)
        .unwrap();
    let first = parse("rome/data/wait/S", "ticket=t1;owner=o", None)
        .unwrap()
        .apply(&mut store, now)
        .unwrap();
    assert!(first.reply.is_some() && first.hold.is_none());
    let second = parse("rome/data/wait/S", "ticket=t2;owner=o;hold_ms=250", None)
        .unwrap()
        .apply(&mut store, now)
        .unwrap();
    assert!(second.reply.is_none());
    assert_eq!(
        second.hold,
        Some(("t2".to_string(), std::time::Duration::from_millis(250)))
    );
    let signalled = parse("rome/data/signal/S", "op=x1", None)
        .unwrap()
        .apply(&mut store, now)
        .unwrap();
    assert_eq!(signalled.grants.len(), 1);
    assert_eq!(signalled.grants[0].ticket, "t2");
}

#[test]
fn a_bad_name_is_named_as_such() {
    let (c, m) = code("rome/data/var/a b", "", None);
    assert_eq!(c, ErrorCode::BadName);
    assert!(m.contains("'a b'"), "{m}");
}

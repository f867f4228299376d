use super::*;
use crate::data::param;
use serde_json::json;
use std::time::Duration;

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
fn a_bad_name_is_named_as_such() {
    let (c, m) = code("rome/data/var/a b", "", None);
    assert_eq!(c, ErrorCode::BadName);
    assert!(m.contains("'a b'"), "{m}");
}

fn name(text: &str) -> Name {
    Name::new(text).unwrap()
}

/// Sends `command` as the client library does and parses it as the
/// server does.
fn round_trip<C: Command>(command: &C) -> Request {
    let root = Root::new("fleet/a").unwrap();
    let params = command.params();
    let text: Vec<String> = params.iter().map(|(k, v)| format!("{k}={v}")).collect();
    let payload = command.payload();
    Request::parse(
        &root,
        &command.key(&root),
        Params::parse(&text.join(";")),
        payload.as_deref(),
    )
    .unwrap_or_else(|e| panic!("{text:?}: {e}"))
}

#[test]
fn every_request_parses_back_as_it_was_encoded() {
    let n = name("r1/Pose");
    for back in [0, 3] {
        let get = Get {
            name: n.clone(),
            back,
        };
        assert_eq!(round_trip(&get), Request::Get(get));
    }
    for op in [None, Some("c7.12".to_string())] {
        let set = Set {
            name: n.clone(),
            value: json!({"x_mm": 1, "seen": [true, null, "a;b=c"]}),
            op: op.clone(),
        };
        assert_eq!(round_trip(&set), Request::Set(set));
        for undo_owner in [None, Some("c7".to_string())] {
            let try_wait = TryWait {
                name: n.clone(),
                op: op.clone(),
                undo_owner,
            };
            assert_eq!(round_trip(&try_wait), Request::TryWait(try_wait));
        }
    }
    for len in [None, Some(1), Some(crate::data::MAX_HISTORY)] {
        let history = History {
            name: n.clone(),
            len,
        };
        assert_eq!(round_trip(&history), Request::History(history));
    }
    let read = Read { name: n.clone() };
    assert_eq!(round_trip(&read), Request::Read(read));
    let create = Create {
        name: n.clone(),
        value: crate::data::MAX_SEMAPHORE_VALUE,
    };
    assert_eq!(round_trip(&create), Request::Create(create));
    for (undo_owner, units) in [
        (None, 1),
        (Some("c7".to_string()), 1),
        (Some("c7".to_string()), 64),
    ] {
        let signal = Signal {
            name: n.clone(),
            op: Some("c7.13".into()),
            undo_owner,
            units,
        };
        assert_eq!(round_trip(&signal), Request::Signal(signal));
    }
    for (ticket, owner, undo, units) in [
        (None, None, false, 1),
        (Some("c7.15".to_string()), Some("c7".to_string()), false, 1),
        (Some("c7.16".to_string()), Some("c7".to_string()), true, 1),
        (Some("c7.17".to_string()), Some("c7".to_string()), true, 64),
    ] {
        let wait = Wait {
            name: n.clone(),
            ticket,
            owner,
            hold: Duration::from_millis(250),
            undo,
            units,
        };
        assert_eq!(round_trip(&wait), Request::Wait(wait));
    }
    let cancel = Cancel {
        name: n.clone(),
        ticket: "c7.15".into(),
    };
    assert_eq!(round_trip(&cancel), Request::Cancel(cancel));
    let ack = Ack {
        name: n,
        ticket: "c7.15".into(),
    };
    assert_eq!(round_trip(&ack), Request::Ack(ack));
}

#[test]
fn an_encoded_request_uses_only_parameters_the_server_knows() {
    // The parameter names come from one list, so a renamed one on either
    // side fails to compile; this checks the values are the parser's too.
    let wait = Wait {
        name: name("S"),
        ticket: Some("t".into()),
        owner: Some("o".into()),
        hold: Duration::from_millis(crate::data::MAX_HOLD_MS),
        undo: true,
        units: 2,
    };
    let keys: Vec<&str> = wait.params().iter().map(|(k, _)| *k).collect();
    assert_eq!(
        keys,
        [
            param::TICKET,
            param::OWNER,
            param::HOLD_MS,
            param::UNDO,
            param::UNITS
        ]
    );
    assert!(matches!(round_trip(&wait), Request::Wait(w) if w == wait));
}

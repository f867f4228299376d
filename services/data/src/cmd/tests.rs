use super::*;
use crate::store::Store;
use rome_clock::Instant;
use rome_schema::Root;

fn parse(key: &str, params: &str) -> Request {
    Request::parse(&Root::default(), key, Params::parse(params), None).unwrap()
}

#[test]
fn wait_is_held_or_answered() {
    let mut store = Store::new(4);
    let now = Instant::now();
    parse("rome/data/create/S", "value=1")
        .apply(&mut store, now)
        .unwrap();
    let first = parse("rome/data/wait/S", "ticket=t1;owner=o")
        .apply(&mut store, now)
        .unwrap();
    assert!(first.reply.is_some() && first.hold.is_none());
    let second = parse("rome/data/wait/S", "ticket=t2;owner=o;hold_ms=250")
        .apply(&mut store, now)
        .unwrap();
    assert!(second.reply.is_none());
    assert_eq!(
        second.hold,
        Some(("t2".to_string(), std::time::Duration::from_millis(250)))
    );
    let signalled = parse("rome/data/signal/S", "op=x1")
        .apply(&mut store, now)
        .unwrap();
    assert_eq!(signalled.grants.len(), 1);
    assert_eq!(signalled.grants[0].ticket, "t2");
}

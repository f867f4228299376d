//! A plain Zenoh session, with no project client code, uses the data
//! server through the keys in docs/keys.md alone.

#![allow(clippy::unwrap_used)]

use rome_schema::data::{Committed, CreateReply, SemState, TryWaitReply};
use rome_schema::{decode, ErrorCode, ErrorReply};
use rome_tests::TestServer;
use serde_json::{json, Value};
use std::time::Duration;
use zenoh::Session;

/// The first reply of a query: Ok(payload) or Err(error reply).
async fn query(
    session: &Session,
    selector: &str,
    payload: Option<&str>,
) -> Result<Vec<u8>, ErrorReply> {
    let mut get = session.get(selector).timeout(Duration::from_secs(5));
    if let Some(p) = payload {
        get = get.payload(p.to_string());
    }
    let replies = get.await.expect("query sent");
    let reply = replies.recv_async().await.expect("a reply");
    match reply.result() {
        Ok(sample) => Ok(sample.payload().to_bytes().into_owned()),
        Err(e) => Err(decode(&e.payload().to_bytes(), "error reply").expect("error reply is JSON")),
    }
}

async fn all(session: &Session, selector: &str) -> Vec<(String, Value)> {
    let replies = session.get(selector).await.expect("query sent");
    let mut out = Vec::new();
    while let Ok(reply) = replies.recv_async().await {
        let sample = reply.result().expect("no error replies to a listing");
        let value = serde_json::from_slice(&sample.payload().to_bytes()).expect("JSON");
        out.push((sample.key_expr().as_str().to_string(), value));
    }
    out.sort_by(|a, b| a.0.cmp(&b.0));
    out
}

async fn server_seen(session: &Session) {
    rome_tests::await_alive(session, "rome/alive/server/data/*", 1).await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn plain_put_get_and_subscribe() {
    let server = TestServer::start().await;
    let z = server.session().await;
    server_seen(&z).await;
    let watch = z.declare_subscriber("rome/data/watch/PosX").await.unwrap();

    for v in [4, 5, 6] {
        z.put("rome/data/var/PosX", v.to_string()).await.unwrap();
    }
    // Same session, same link: the server sees the puts before this get.
    let now = query(&z, "rome/data/var/PosX", None).await.unwrap();
    assert_eq!(serde_json::from_slice::<Value>(&now).unwrap(), json!(6));
    let older = query(&z, "rome/data/var/PosX?back=2", None).await.unwrap();
    assert_eq!(serde_json::from_slice::<Value>(&older).unwrap(), json!(4));

    for expect in 1..=3u64 {
        let s = tokio::time::timeout(Duration::from_secs(5), watch.recv_async())
            .await
            .expect("commit published")
            .unwrap();
        let c: Committed = decode(&s.payload().to_bytes(), "commit").unwrap();
        assert_eq!((c.seq, c.value), (expect, Some(json!(3 + expect))));
    }

    // An acknowledged write with a JSON object, then a listing with a wildcard.
    let ack = query(&z, "rome/data/set/Pose", Some(r#"{"x_mm":1,"y_mm":2}"#))
        .await
        .unwrap();
    assert_eq!(
        serde_json::from_slice::<Value>(&ack).unwrap(),
        json!({"name":"Pose","seq":1})
    );
    let vars = all(&z, "rome/data/var/**").await;
    assert_eq!(
        vars,
        vec![
            ("rome/data/var/PosX".to_string(), json!(6)),
            ("rome/data/var/Pose".to_string(), json!({"x_mm":1,"y_mm":2})),
        ]
    );

    // A delete is a commit too, and the value is gone.
    z.delete("rome/data/var/PosX").await.unwrap();
    let s = watch.recv_async().await.unwrap();
    let c: Committed = decode(&s.payload().to_bytes(), "commit").unwrap();
    assert!(c.deleted && c.seq == 4);
    let gone = query(&z, "rome/data/var/PosX", None).await.unwrap_err();
    assert_eq!(gone.code, ErrorCode::UnknownVariable);
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn plain_semaphores() {
    let server = TestServer::start().await;
    let z = server.session().await;
    server_seen(&z).await;
    let created: CreateReply = decode(
        &query(&z, "rome/data/create/GoalData?value=1", None)
            .await
            .unwrap(),
        "create",
    )
    .unwrap();
    assert!(created.created);
    let t: TryWaitReply = decode(
        &query(&z, "rome/data/try-wait/GoalData", None)
            .await
            .unwrap(),
        "try",
    )
    .unwrap();
    assert!(t.acquired);
    // A plain put on the signal key signals, with no reply.
    z.put("rome/data/signal/GoalData", "").await.unwrap();
    let state: SemState = decode(
        &query(&z, "rome/data/sem/GoalData", None).await.unwrap(),
        "sem",
    )
    .unwrap();
    assert_eq!((state.value, state.waiters), (1, 0));
    // An anonymous wait (as from z_get) is granted at once when a unit is free …
    let w = query(&z, "rome/data/wait/GoalData?hold_ms=1000", None)
        .await
        .unwrap();
    assert!(String::from_utf8_lossy(&w).contains("\"granted\""));
    // … and times out without taking anything when none comes.
    let w = query(&z, "rome/data/wait/GoalData?hold_ms=100", None)
        .await
        .unwrap();
    assert!(String::from_utf8_lossy(&w).contains("\"timed_out\""));
    let state: SemState = decode(
        &query(&z, "rome/data/sem/GoalData", None).await.unwrap(),
        "sem",
    )
    .unwrap();
    assert_eq!((state.value, state.waiters), (0, 0));
    // Everything at once: `get rome/**` shows the whole data server.
    let everything = all(&z, "rome/**").await;
    assert!(
        everything
            .iter()
            .any(|(k, _)| k == "rome/data/sem/GoalData"),
        "{everything:?}"
    );
    server.stop().await;
}

/// Runs `each` on two sessions at once, each with a name of its own; a
/// failure in either fails the test.
async fn both<F, Fut>(a: &Session, b: &Session, names: [&'static str; 2], each: F)
where
    F: Fn(Session, &'static str) -> Fut,
    Fut: std::future::Future<Output = ()> + Send + 'static,
{
    let (x, y) = tokio::join!(
        tokio::spawn(each(a.clone(), names[0])),
        tokio::spawn(each(b.clone(), names[1]))
    );
    x.unwrap();
    y.unwrap();
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_read_right_after_a_plain_put_sees_it() {
    // A read that finds nothing queued is answered from the queryable's
    // callback; one behind a put still on its way must wait for it. Two
    // writers and readers at once, so reads often find the other's put in
    // the queue and sometimes none.
    let server = TestServer::start().await;
    let (a, b) = (server.session().await, server.session().await);
    server_seen(&a).await;
    server_seen(&b).await;
    let run = |z: Session, name: &'static str| async move {
        for k in 0..300u32 {
            z.put(format!("rome/data/var/{name}"), k.to_string())
                .await
                .unwrap();
            let got = query(&z, &format!("rome/data/var/{name}"), None)
                .await
                .unwrap();
            assert_eq!(
                String::from_utf8_lossy(&got),
                k.to_string(),
                "{name}: read {k} did not see the put before it"
            );
        }
    };
    both(&a, &b, ["Ryw1", "Ryw2"], run).await;
    // The same across keys of one name: a plain put on `signal/NAME`, then
    // a read of `sem/NAME`.
    let signals = |z: Session, name: &'static str| async move {
        query(&z, &format!("rome/data/create/{name}?value=0"), None)
            .await
            .unwrap();
        for k in 1..=200u32 {
            z.put(format!("rome/data/signal/{name}"), "").await.unwrap();
            let state: SemState = decode(
                &query(&z, &format!("rome/data/sem/{name}"), None)
                    .await
                    .unwrap(),
                "sem",
            )
            .unwrap();
            assert_eq!(
                state.value,
                u64::from(k),
                "{name}: read {k} missed the signal before it"
            );
        }
    };
    both(&a, &b, ["RywSem1", "RywSem2"], signals).await;
    server.stop().await;
}

//! Every malformed or impossible request gets an error reply naming the
//! problem, over real Zenoh, and the server keeps serving everyone else.

#![allow(clippy::unwrap_used)]

use rome_schema::data::Rejected;
use rome_schema::{decode, ErrorCode, ErrorReply};
use rome_tests::TestServer;
use std::time::Duration;
use zenoh::Session;

async fn refused(z: &Session, selector: &str, payload: Option<&[u8]>) -> ErrorReply {
    let mut get = z.get(selector).timeout(Duration::from_secs(5));
    if let Some(p) = payload {
        get = get.payload(p.to_vec());
    }
    let reply = get
        .await
        .unwrap()
        .recv_async()
        .await
        .expect("a reply, not silence");
    let err = reply.result().expect_err("an error reply");
    decode(&err.payload().to_bytes(), "error reply").unwrap()
}

/// Runs one bad request against a fresh server, then checks the server
/// still serves a good one from another client.
async fn case(selector: &str, payload: Option<&[u8]>, code: ErrorCode, words: &[&str]) {
    let server = TestServer::start().await;
    let good = server.client("good").await;
    good.create_semaphore("S", 0).await.unwrap();
    good.set("PosX", &1).await.unwrap();
    let z = server.session().await;
    let e = refused(&z, selector, payload).await;
    assert_eq!(e.code, code, "{selector}: {}", e.message);
    for w in words {
        assert!(
            e.message.contains(w),
            "{selector}: '{}' lacks '{w}'",
            e.message
        );
    }
    good.set("PosX", &2).await.unwrap();
    assert_eq!(good.get("PosX").await.unwrap(), serde_json::json!(2));
    assert!(!good.try_wait("S").await.unwrap());
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_json() {
    case(
        "rome/data/set/PosX",
        Some(b"{\"x_mm\": 1"),
        ErrorCode::BadJson,
        &["PosX"],
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn empty_value() {
    case("rome/data/set/PosX", None, ErrorCode::BadJson, &["empty"]).await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unknown_semaphore() {
    for op in ["signal", "wait", "try-wait", "sem"] {
        case(
            &format!("rome/data/{op}/Nope"),
            None,
            ErrorCode::UnknownSemaphore,
            &["Nope"],
        )
        .await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn negative_history() {
    case(
        "rome/data/history/PosX?len=-3",
        None,
        ErrorCode::OutOfRange,
        &["len", "-3"],
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn wrong_type() {
    case(
        "rome/data/history/PosX?len=abc",
        None,
        ErrorCode::WrongType,
        &["len", "abc"],
    )
    .await;
    case(
        "rome/data/create/T?value=yes",
        None,
        ErrorCode::WrongType,
        &["value", "yes"],
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unknown_variable_and_back_out_of_range() {
    case(
        "rome/data/var/Nope",
        None,
        ErrorCode::UnknownVariable,
        &["Nope"],
    )
    .await;
    case(
        "rome/data/var/PosX?back=3",
        None,
        ErrorCode::OutOfRange,
        &["back=3"],
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn unknown_key_and_parameter() {
    case(
        "rome/data/frobnicate/x",
        None,
        ErrorCode::UnknownKey,
        &["frobnicate"],
    )
    .await;
    case(
        "rome/data/var/PosX?bakc=1",
        None,
        ErrorCode::BadParameter,
        &["bakc"],
    )
    .await;
    case(
        "rome/data/create/T",
        None,
        ErrorCode::BadParameter,
        &["value=N"],
    )
    .await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_put_is_reported_on_rejected_and_not_recorded() {
    let server = TestServer::start().await;
    let good = server.client("good").await;
    let z = server.session().await;
    let rejected = z.declare_subscriber("rome/data/rejected").await.unwrap();
    good.set("PosX", &1).await.unwrap();
    // A query answered by the server over the same link proves the
    // subscriber's declaration (sent before it) has reached the server.
    let reply = z
        .get("rome/data/var/PosX")
        .await
        .unwrap()
        .recv_async()
        .await
        .unwrap();
    assert!(reply.result().is_ok());
    z.put("rome/data/var/PosX", "not json").await.unwrap();
    let r = tokio::time::timeout(Duration::from_secs(10), rejected.recv_async())
        .await
        .expect("rejection published")
        .unwrap();
    let r: Rejected = decode(&r.payload().to_bytes(), "rejected").unwrap();
    assert_eq!(r.code, ErrorCode::BadJson);
    assert_eq!(r.key, "rome/data/var/PosX");
    assert_eq!(good.get("PosX").await.unwrap(), serde_json::json!(1));
    assert_eq!(good.history("PosX").await.unwrap().seq, 1);
    // A put on a key that is no valid variable name is reported too.
    z.put("rome/data/var/a b", "1").await.unwrap();
    let r = tokio::time::timeout(Duration::from_secs(10), rejected.recv_async())
        .await
        .expect("rejection published")
        .unwrap();
    let r: Rejected = decode(&r.payload().to_bytes(), "rejected").unwrap();
    assert_eq!(
        (r.code, r.key.as_str()),
        (ErrorCode::BadName, "rome/data/var/a b")
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn value_too_large() {
    let big = vec![b'1'; rome_schema::data::MAX_VALUE_BYTES + 1];
    case(
        "rome/data/set/PosX",
        Some(&big),
        ErrorCode::OutOfRange,
        &["limit"],
    )
    .await;
}

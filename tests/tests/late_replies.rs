//! A reply that comes after a client took its answer is dropped without a
//! word. Zenoh's own reply channels log each one as an error ("sending on
//! a closed channel"), and such replies are part of normal work: a second
//! server answering beside the first, or Zenoh's timeout reply to a query
//! whose end came late over a lossy link. The logs of a long fleet run
//! were dotted with that error.

#![allow(clippy::unwrap_used)]

use rome_client::{DataClient, DataOptions};
use rome_tests::TestServer;
use std::io::Write;
use std::sync::{Arc, Mutex};
use tokio::sync::oneshot;
use zenoh::Wait;

/// Where this binary's log lines go, to be read back.
#[derive(Clone, Default)]
struct Captured(Arc<Mutex<Vec<u8>>>);

impl Write for Captured {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(buf);
        Ok(buf.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

impl Captured {
    fn text(&self) -> String {
        String::from_utf8_lossy(&self.0.lock().unwrap()).into_owned()
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_reply_after_the_answer_was_taken_is_dropped_without_an_error() {
    // Zenoh answers and logs on its own threads: only a global subscriber
    // sees them (this binary has this one test).
    let log = Captured::default();
    let writer = log.clone();
    tracing_subscriber::fmt()
        .with_writer(move || writer.clone())
        .with_max_level(tracing_subscriber::filter::LevelFilter::WARN)
        .with_ansi(false)
        .init();

    let server = TestServer::start().await;
    let session = server.session().await;
    let ds = DataClient::connect(&session, DataOptions::new("reader"))
        .await
        .unwrap();
    ds.set("late/x", &1i64).await.unwrap();

    // A second answerer beside the data server, on the server's session:
    // it holds the first query it sees until told, then replies to it,
    // then answers a probe on the same link.
    let (go_tx, go_rx) = oneshot::channel::<()>();
    let (sent_tx, sent_rx) = oneshot::channel::<()>();
    let late = server
        .session
        .declare_queryable("rome/data/**")
        .await
        .unwrap();
    let probe = server
        .session
        .declare_queryable("late/probe")
        .callback(|q| {
            let key = q.key_expr().clone();
            q.reply(key, "here").wait().unwrap();
        })
        .await
        .unwrap();
    let answering = tokio::spawn(async move {
        // Anything else the client asks is answered by the data server
        // alone.
        let query = loop {
            let q = late.recv_async().await.unwrap();
            if q.key_expr().as_str().ends_with("late/x") {
                break q;
            }
        };
        go_rx.await.unwrap();
        let key = query.key_expr().clone();
        query.reply(key, "late").await.unwrap();
        drop(query);
        sent_tx.send(()).unwrap();
        late
    });
    // The data server's answer is taken ...
    let got = ds.get("late/x").await.unwrap();
    assert_eq!(got, serde_json::json!(1));
    // ... and only then does the second answerer reply.
    go_tx.send(()).unwrap();
    sent_rx.await.unwrap();
    // The probe's reply follows the late one on the same link, at the
    // same priority: once it is here, the late one was handed over.
    let replies = session.get("late/probe").await.unwrap();
    let here = replies.recv_async().await.unwrap();
    assert!(here.result().is_ok());
    let _late = answering.await.unwrap();
    drop(probe);

    let text = log.text();
    assert!(
        !text.contains("closed channel"),
        "a late reply was logged as an error:\n{text}"
    );
    server.stop().await;
}

//! A watcher sees every committed write exactly once, in commit order
//! per variable, whether it came from a plain put or an acknowledged set.

#![allow(clippy::unwrap_used)]

use rome_tests::TestServer;
use serde_json::json;
use std::collections::HashMap;
use std::time::Duration;

/// Writes by each writer; half the writers put, half set.
const PER_WRITER: u64 = 400;
const WRITERS: u64 = 4;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_commit_once_in_order() {
    let server = TestServer::start().await;
    let watcher = server.client("watcher").await;
    let mut watch = watcher.watch("**").await.unwrap();
    // The subscription must reach the server before the first write.
    watcher.set("ready", &true).await.unwrap();
    let first = tokio::time::timeout(Duration::from_secs(10), watch.next())
        .await
        .expect("ready seen")
        .unwrap()
        .unwrap();
    assert_eq!(first.name, "ready");

    // Read while they write, as a watcher does: what is under test is the
    // order the server publishes in, not how much a silent reader buffers.
    let (seen_tx, mut seen_rx) = tokio::sync::mpsc::unbounded_channel();
    let reader = tokio::spawn(async move {
        while let Some(c) = watch.next().await {
            if seen_tx.send(c.unwrap()).is_err() {
                break;
            }
        }
    });

    // Plain puts reach the server's event loop; sets are answered from
    // the queryable's callback when nothing is queued: the two race for
    // the same variables.
    let mut writers = Vec::new();
    for w in 0..WRITERS {
        let session = server.session().await;
        let ds =
            rome_client::DataClient::connect(&session, rome_client::DataOptions::new("writer"))
                .await
                .unwrap();
        writers.push(tokio::spawn(async move {
            for i in 0..PER_WRITER {
                let var = if i % 2 == 0 { "a" } else { "b" };
                if w % 2 == 0 {
                    session
                        .put(
                            format!("rome/data/var/{var}"),
                            json!({"w": w, "i": i}).to_string(),
                        )
                        .await
                        .unwrap();
                } else {
                    ds.set(var, &json!({"w": w, "i": i})).await.unwrap();
                }
            }
            // A query on the same link follows its puts: once answered,
            // every put that reached the server is committed. (A flood of
            // plain puts may lose some on the way; a put promises nothing.)
            ds.history("a").await.unwrap();
        }));
    }
    for w in writers {
        w.await.unwrap();
    }
    let mut committed = 0;
    for var in ["a", "b"] {
        committed += watcher.history(var).await.unwrap().seq as usize;
    }
    let mut seen = Vec::with_capacity(committed);
    while seen.len() < committed {
        match tokio::time::timeout(Duration::from_secs(10), seen_rx.recv()).await {
            Ok(Some(c)) => seen.push(c),
            _ => panic!("{} of {committed} commits seen", seen.len()),
        }
    }
    let acknowledged = seen
        .iter()
        .filter(|c| c.value.as_ref().unwrap()["w"].as_u64().unwrap() % 2 == 1)
        .count();
    assert_eq!(
        acknowledged,
        (WRITERS / 2 * PER_WRITER) as usize,
        "every acknowledged set is seen"
    );
    let mut seqs: HashMap<String, Vec<u64>> = HashMap::new();
    let mut last_from: HashMap<(String, u64), u64> = HashMap::new();
    for c in seen {
        let v = c.value.clone().unwrap();
        let (w, i) = (v["w"].as_u64().unwrap(), v["i"].as_u64().unwrap());
        // Each writer's own writes keep their order.
        if let Some(prev) = last_from.insert((c.name.clone(), w), i) {
            assert!(i > prev, "writer {w}'s writes to {} reordered", c.name);
        }
        seqs.entry(c.name).or_default().push(c.seq);
    }
    for (name, s) in &seqs {
        let expect: Vec<u64> = (1..=s.len() as u64).collect();
        assert_eq!(s, &expect, "commits of {name} not each once in order");
    }
    // Nothing more: no duplicate arrives late.
    assert!(
        tokio::time::timeout(Duration::from_millis(300), seen_rx.recv())
            .await
            .is_err()
    );
    reader.abort();
    server.stop().await;
}

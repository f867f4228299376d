//! A watcher sees every committed write exactly once, in commit order
//! per variable, whether it came from a plain put or an acknowledged set.

#![allow(clippy::unwrap_used)]

use rome_tests::TestServer;
use serde_json::json;
use std::collections::HashMap;
use std::time::Duration;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_commit_once_in_order() {
    const PER_WRITER: u64 = 100;
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

    let mut writers = Vec::new();
    for w in 0..3u64 {
        let ds = server.client("writer").await;
        let plain = server.session().await;
        writers.push(tokio::spawn(async move {
            for i in 0..PER_WRITER {
                let var = if i % 2 == 0 { "a" } else { "b" };
                if w == 2 {
                    plain
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
        }));
    }
    for w in writers {
        w.await.unwrap();
    }
    let total = 3 * PER_WRITER as usize;
    let mut seqs: HashMap<String, Vec<u64>> = HashMap::new();
    let mut last_from: HashMap<(String, u64), u64> = HashMap::new();
    for _ in 0..total {
        let c = tokio::time::timeout(Duration::from_secs(10), watch.next())
            .await
            .expect("every commit arrives")
            .unwrap()
            .unwrap();
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
    assert_eq!(seqs.values().map(Vec::len).sum::<usize>(), total);
    // Nothing more: no duplicate arrives late.
    assert!(
        tokio::time::timeout(Duration::from_millis(300), watch.next())
            .await
            .is_err()
    );
    server.stop().await;
}

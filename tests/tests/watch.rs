//! A watcher sees every committed write exactly once, in commit order
//! per variable, whether it came from a plain put or an acknowledged set.

#![allow(clippy::unwrap_used)]

use rome_client::Watch;
use rome_schema::data::Committed;
use rome_tests::TestServer;
use serde_json::json;
use std::collections::HashMap;
use std::time::Duration;

/// The next commit `watch` returns within 10 s; else a panic saying
/// `what` was awaited (told the watch, to report what it has missed).
async fn next_commit(watch: &mut Watch, what: impl FnOnce(&Watch) -> String) -> Committed {
    match tokio::time::timeout(Duration::from_secs(10), watch.next()).await {
        Ok(Some(c)) => c.unwrap(),
        Ok(None) => panic!("the watch ended: {}", what(watch)),
        Err(_) => panic!("not within 10 s: {}", what(watch)),
    }
}

/// Writes by each writer; half the writers put, half set.
const PER_WRITER: u64 = 400;
const WRITERS: u64 = 4;

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn every_commit_once_in_order() {
    let server = TestServer::start().await;
    let watcher = server.client("watcher").await;
    let mut watch = watcher.watch("**").await.unwrap();
    // Beside the library's watch, which skips a commit older than one it
    // has returned, the publications exactly as they arrive.
    let raw_session = server.session().await;
    let (raw_tx, mut raw_rx) = tokio::sync::mpsc::unbounded_channel();
    let _raw = raw_session
        .declare_subscriber("rome/data/watch/**")
        .callback(move |s| {
            let c: Committed = serde_json::from_slice(&s.payload().to_bytes()).unwrap();
            let _ = raw_tx.send((c.name, c.seq));
        })
        .await
        .unwrap();
    // Both subscriptions must reach the server before the first write: a
    // query on a subscriber's own link follows its declaration there.
    rome_client::DataClient::connect(&raw_session, rome_client::DataOptions::new("raw"))
        .await
        .unwrap()
        .list()
        .await
        .unwrap();
    watcher.set("ready", &true).await.unwrap();
    let first = next_commit(&mut watch, |_| "ready seen".into()).await;
    assert_eq!(first.name, "ready");
    let raw_first = tokio::time::timeout(Duration::from_secs(10), raw_rx.recv())
        .await
        .expect("ready seen by the plain subscriber");
    assert_eq!(raw_first, Some(("ready".to_string(), 1)));

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
    // As published: each variable's commits once each, in commit order.
    let mut raw: HashMap<String, Vec<u64>> = HashMap::new();
    for _ in 0..committed {
        let (name, seq) = tokio::time::timeout(Duration::from_secs(10), raw_rx.recv())
            .await
            .expect("every publication arrives at the plain subscriber")
            .unwrap();
        raw.entry(name).or_default().push(seq);
    }
    for (name, s) in &raw {
        let expect: Vec<u64> = (1..=s.len() as u64).collect();
        assert_eq!(
            s, &expect,
            "publications of {name} not each once in commit order"
        );
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

/// A reader that stops to ask the server something while commits pile up
/// gets its answer: the commits wait in the watch's own queue, not in the
/// link, where they would hold the answer back behind them.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_reader_that_asks_while_commits_pile_up_gets_its_answer() {
    const WRITES: usize = 2_000;
    let server = TestServer::start().await;
    let reader = server.client("reader").await;
    let mut watch = reader.watch("burst").await.unwrap();
    // The writer's link is another: the subscription must have reached
    // the server first, which a query on its own link after it shows.
    reader.list().await.unwrap();
    let writer = server.client("writer").await;
    writer.set("burst", &0).await.unwrap();
    next_commit(&mut watch, |_| "the first commit arrives".into()).await;
    for i in 1..WRITES {
        writer.set("burst", &i).await.unwrap();
    }
    // Most of the commits are on their way ahead of this answer.
    let last = tokio::time::timeout(Duration::from_secs(20), reader.get("burst"))
        .await
        .expect("the reader's get is answered while its watch is unread")
        .unwrap();
    assert_eq!(last, json!(WRITES - 1));
    let mut seen = 1;
    while seen < WRITES {
        let c = next_commit(&mut watch, |_| format!("{seen} of {WRITES} commits seen")).await;
        seen += 1;
        assert_eq!(c.seq, seen as u64);
    }
    assert_eq!(watch.missed(), 0);
    server.stop().await;
}

/// A reader that falls further behind than its backlog loses the commits
/// beyond it, counted, and is not stopped: what comes after arrives.
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn commits_beyond_the_backlog_are_counted_as_missed() {
    const WRITES: u64 = 100;
    let server = TestServer::start().await;
    let mut options = rome_client::DataOptions::new("reader");
    options.watch_backlog = 10_000;
    let reader = server.client_with(options).await;
    let mut watch = reader.watch("big").await.unwrap();
    // The writer's link is another: the subscription must have reached
    // the server first, which a query on its own link after it shows.
    reader.list().await.unwrap();
    let writer = server.client("writer").await;
    let value = "x".repeat(1_000);
    writer.set("big", &value).await.unwrap();
    next_commit(&mut watch, |_| "the first commit arrives".into()).await;
    for _ in 1..WRITES {
        writer.set("big", &value).await.unwrap();
    }
    // Each commit is either kept and read, or counted as missed.
    let mut seqs = vec![1];
    while seqs.len() as u64 + watch.missed() < WRITES {
        let c = next_commit(&mut watch, |w| {
            format!("seen {seqs:?}, missed {}", w.missed())
        })
        .await;
        seqs.push(c.seq);
    }
    let missed = watch.missed();
    assert!(missed > 0, "a 10 kB backlog held 100 commits of 1 kB");
    assert!(seqs.len() > 1, "the backlog kept nothing");
    assert!(
        seqs.windows(2).all(|w| w[0] < w[1]),
        "out of order: {seqs:?}"
    );
    assert_eq!(
        seqs.len() as u64 + missed,
        WRITES,
        "seen {seqs:?}, missed {missed}"
    );
    // Caught up, the reader sees the next commit.
    writer.set("big", &"after").await.unwrap();
    let next = next_commit(&mut watch, |_| "a commit after the gap arrives".into()).await;
    assert_eq!(next.seq, WRITES + 1);
    server.stop().await;
}

/// A watch over a slow link: `watch` returns only once the server knows of
/// the subscription, so a commit another client makes right after is seen
/// (the subscription's declaration takes 150 ms to cross; the other
/// client's write does not wait for it).
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_commit_made_just_after_watch_returns_is_seen_over_a_slow_link() {
    let server = TestServer::start().await;
    let (_relay, far) = rome_tests::far_session(server.port, Duration::from_millis(150)).await;
    let watcher = rome_client::DataClient::connect(&far, rome_client::DataOptions::new("watcher"))
        .await
        .unwrap();
    let writer = server.client("writer").await;
    let mut watch = watcher.watch("Slow").await.unwrap();
    writer.set("Slow", &json!(1)).await.unwrap();
    let c = next_commit(&mut watch, |w| {
        format!(
            "the commit made right after `watch` ({} missed)",
            w.missed()
        )
    })
    .await;
    assert_eq!((c.name.as_str(), c.seq), ("Slow", 1));
}

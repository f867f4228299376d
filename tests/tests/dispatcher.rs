//! The fleet's dispatcher against a real data server, with robots played
//! by hand through their `Duty` variables: one dispatcher at a time, the
//! second taking over with every open task; values that are not what
//! they should be fail their task or are skipped, and the dispatcher
//! goes on; a robot that reports failure gives its task back.

#![allow(clippy::unwrap_used)]

use rome_client::DataClient;
use rome_nav::fleet::dispatcher::Note;
use rome_nav::fleet::schema::{
    duty_var, task_var, Assignment, Duty, DutyState, Outcome, TaskSpec, TaskState, TaskStatus,
};
use rome_nav::fleet::tasks;
use rome_tests::{eventually, TestServer};
use serde_json::json;
use std::time::Duration;
use tokio::sync::mpsc;

const WITHIN: Duration = Duration::from_secs(20);

/// A dispatcher on a session of its own, its notes on a channel.
async fn dispatcher(
    server: &TestServer,
) -> (
    tokio::task::JoinHandle<()>,
    zenoh::Session,
    mpsc::UnboundedReceiver<Note>,
) {
    let (d, session) = rome_tests::eb3_dispatcher(server).await;
    let (tx, rx) = mpsc::unbounded_channel();
    let task = tokio::spawn(async move {
        let _ = d
            .run(|n| {
                let _ = tx.send(n);
            })
            .await;
    });
    (task, session, rx)
}

async fn next_note(rx: &mut mpsc::UnboundedReceiver<Note>, what: &str) -> Note {
    tokio::time::timeout(WITHIN, rx.recv())
        .await
        .unwrap_or_else(|_| panic!("no note: {what}"))
        .unwrap()
}

async fn status(ds: &DataClient, id: &str) -> Option<TaskStatus> {
    ds.get_as(&format!("fleet/status/{id}")).await.ok()
}

fn to(place: &str) -> TaskSpec {
    TaskSpec {
        to: place.into(),
        robot: None,
        priority: 0,
        via: vec![],
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_second_dispatcher_waits_and_takes_over_every_open_task() {
    let server = TestServer::start().await;
    let ds = server.client("test").await;
    let (first, first_session, mut first_notes) = dispatcher(&server).await;
    assert_eq!(
        next_note(&mut first_notes, "the first runs").await,
        Note::Running { tasks: 0 }
    );
    let (_second, _s, mut second_notes) = dispatcher(&server).await;
    assert_eq!(
        next_note(&mut second_notes, "the second waits").await,
        Note::Waiting
    );
    let id = tasks::add(&ds, &to("356R")).await.unwrap();
    eventually(WITHIN, "the first dispatcher queues the task", || async {
        status(&ds, &id)
            .await
            .is_some_and(|s| s.state == TaskState::Queued)
    })
    .await;
    // The first one dies: its liveliness goes, and with it its unit.
    first.abort();
    first_session.close().await.unwrap();
    assert_eq!(
        next_note(&mut second_notes, "the second takes over").await,
        Note::Running { tasks: 1 }
    );
    server.stop().await;
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn bad_values_fail_their_task_or_are_skipped_and_a_failed_robot_gives_its_task_back() {
    let server = TestServer::start().await;
    let ds = server.client("test").await;
    let (_d, _s, mut notes) = dispatcher(&server).await;
    next_note(&mut notes, "it runs").await;

    // A task that is not one, and a robot's duty that is not one.
    ds.set("fleet/task/bad", &json!({"to": 5})).await.unwrap();
    ds.set(&duty_var("rx"), &json!("garbage")).await.unwrap();
    eventually(WITHIN, "the bad task fails with the reason", || async {
        status(&ds, "bad").await.is_some_and(|s| {
            s.state == TaskState::Failed
                && s.why[0].contains("fleet/task/bad is not what it should be")
        })
    })
    .await;

    // A robot played by hand: idle at 350R, its owner this live client.
    let mut duty = Duty {
        at: "350R".into(),
        at_mm: None,
        state: DutyState::Idle,
        task: None,
        owner: ds.owner().to_string(),
        last: None,
    };
    ds.set(&duty_var("r1"), &duty).await.unwrap();
    let id = tasks::add(&ds, &to("356R")).await.unwrap();
    eventually(WITHIN, "the task is handed to r1", || async {
        let told: Option<Assignment> = ds.get_as(&task_var("r1")).await.unwrap_or(None);
        told.is_some_and(|a| a.task == id && a.to == "356R")
    })
    .await;
    assert_eq!(status(&ds, &id).await.unwrap().state, TaskState::Assigned);

    // r1 reports that it did not get there: the task goes back to the
    // queue, saying why, and is not given to r1 again.
    duty.last = Some(Outcome {
        task: id.clone(),
        ok: false,
        why: Some("blocked by a cart".into()),
    });
    ds.set(&duty_var("r1"), &duty).await.unwrap();
    ds.signal("$fleet/wake").await.unwrap();
    eventually(WITHIN, "the task is back in the queue", || async {
        status(&ds, &id).await.is_some_and(|s| {
            s.state == TaskState::Queued
                && s.tried == ["r1"]
                && s.why == ["r1 did not arrive: blocked by a cart"]
        })
    })
    .await;

    // Cancelled, it ends with the reason.
    tasks::cancel(&ds, &id, Some("not needed")).await.unwrap();
    eventually(WITHIN, "the task is cancelled", || async {
        status(&ds, &id).await.is_some_and(|s| {
            s.state == TaskState::Cancelled && s.why.last().unwrap() == "cancelled: not needed"
        })
    })
    .await;
    assert!(tasks::cancel(&ds, "T999", None)
        .await
        .unwrap_err()
        .to_string()
        .contains("there is no task 'T999'"),);
    server.stop().await;
}

//! The Planner/Navigator hand-over of Table 5.4, by two separate processes.

#![allow(clippy::unwrap_used)]

use rome_client::goals::{Goal, GoalType};
use rome_tests::{peer, TestServer};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thousand_goals_between_two_processes_none_lost_none_duplicated_in_order() {
    const GOALS: u32 = 1000;
    let server = TestServer::start().await;
    let n = GOALS.to_string();
    let mut navigator = peer!(server.port, ["navigator", "--goals", n.as_str()]);
    let mut planner = peer!(server.port, ["planner", "--goals", n.as_str()]);
    let (nav_out, plan_out) =
        tokio::task::spawn_blocking(move || (navigator.output(), planner.output()))
            .await
            .unwrap();
    assert!(plan_out.is_empty());
    let received: Vec<Goal> = nav_out
        .lines()
        .map(|l| serde_json::from_str(l).expect("a goal per line"))
        .collect();
    assert_eq!(received.len(), GOALS as usize, "goals lost or duplicated");
    let kinds = [GoalType::L, GoalType::D, GoalType::C, GoalType::E];
    for (i, g) in received.iter().enumerate() {
        let expect = Goal {
            goal_type: kinds[i % 4],
            distance: i as i64,
            direction_deg: (i % 360) as i64,
        };
        assert_eq!(*g, expect, "goal {i} out of order or garbled");
    }
    // Both semaphores are back at rest: nothing left over, nobody queued.
    let ds = server.client("check").await;
    for sem in ["$GoalData", "$RobotStatus"] {
        let s = ds.semaphore(sem).await.unwrap();
        assert_eq!((s.value, s.waiters), (0, 0), "{sem}");
    }
    server.stop().await;
}

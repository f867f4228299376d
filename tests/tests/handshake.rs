//! The Planner/Navigator hand-over of Table 5.4, by separate processes
//! running the navigation clients' own blackboard (`rome_nav::board`),
//! two robots at once on one data server.

#![allow(clippy::unwrap_used)]

use rome_nav::board::{Board, Goal, GoalType, Sem};
use rome_tests::{peer, TestServer};

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn thousand_goals_per_robot_between_processes_none_lost_none_crossed_in_order() {
    const GOALS: u32 = 1000;
    let server = TestServer::start().await;
    let n = GOALS.to_string();
    let mut pairs = Vec::new();
    for robot in ["r1", "r2"] {
        let navigator = peer!(
            server.port,
            ["navigator", "--goals", n.as_str(), "--robot", robot]
        );
        let planner = peer!(
            server.port,
            ["planner", "--goals", n.as_str(), "--robot", robot]
        );
        pairs.push((robot, navigator, planner));
    }
    // Each child's output is drained on a thread of its own, so no pipe
    // fills while another child is being read.
    let drains: Vec<_> = pairs
        .into_iter()
        .map(|(robot, mut nav, mut plan)| {
            let nav = tokio::task::spawn_blocking(move || nav.output());
            let plan = tokio::task::spawn_blocking(move || plan.output());
            (robot, nav, plan)
        })
        .collect();
    let mut outputs = Vec::new();
    for (robot, nav, plan) in drains {
        outputs.push((robot, nav.await.unwrap(), plan.await.unwrap()));
    }
    let kinds = [GoalType::L, GoalType::D, GoalType::C, GoalType::E];
    for (robot, nav_out, plan_out) in outputs {
        assert!(plan_out.is_empty(), "{robot}'s planner printed {plan_out}");
        let received: Vec<Goal> = nav_out
            .lines()
            .map(|l| serde_json::from_str(l).expect("a goal per line"))
            .collect();
        assert_eq!(
            received.len(),
            GOALS as usize,
            "{robot}: goals lost or duplicated"
        );
        for (i, g) in received.iter().enumerate() {
            let expect = Goal {
                goal_type: kinds[i % 4],
                distance: i as i64,
                direction_deg: (i % 360) as f64,
            };
            assert_eq!(*g, expect, "{robot}: goal {i} out of order or garbled");
        }
    }
    // Each robot's semaphores are back at rest: nothing left over, nobody
    // queued, and nothing under the unscoped thesis names.
    let ds = server.client("check").await;
    for robot in ["r1", "r2"] {
        let board = Board::new(ds.clone(), robot);
        for sem in [Sem::GoalData, Sem::RobotStatus] {
            let s = ds.semaphore(&board.sem_name(sem)).await.unwrap();
            assert_eq!((s.value, s.waiters), (0, 0), "{robot} {sem:?}");
        }
    }
    assert!(ds.semaphore("$GoalData").await.is_err());
    server.stop().await;
}

//! Which free robot takes which waiting task: the dispatcher's choice,
//! kept apart from the data server so it can be tested alone.
//!
//! Tasks go in order of priority (higher first), then in the order they
//! were added. Each takes the free robot with the shortest route from
//! where it stands to the task's goal; a task pinned to a robot waits for
//! that robot; a robot a task was already taken from is not given it
//! again. Greedy, as a human dispatcher with a list would be: a task is
//! never kept waiting for a better robot while one that can do it is free.

use super::schema::TaskStatus;

/// A robot free to take a task.
#[derive(Debug, Clone, PartialEq)]
pub struct Free {
    /// Its name.
    pub name: String,
    /// The position it stands at (`@x,y` between positions).
    pub at: String,
    /// Where it stands, mm, when that is not a named position.
    pub at_mm: Option<[f64; 2]>,
}

/// A waiting task as the choice needs it.
#[derive(Debug, Clone, PartialEq)]
pub struct Waiting<'a> {
    /// Its status (id, goal, priority, order, robots tried).
    pub status: &'a TaskStatus,
    /// The robot it is pinned to.
    pub robot: Option<&'a str>,
}

/// Pairs waiting tasks with free robots: `(task id, robot)`, in the order
/// the tasks were chosen. `length(robot, to)` is the route length in mm
/// from where the robot stands, `None` where there is no route.
pub fn assign(
    waiting: &[Waiting<'_>],
    free: &[Free],
    mut length: impl FnMut(&Free, &str) -> Option<f64>,
) -> Vec<(String, String)> {
    let mut order: Vec<&Waiting<'_>> = waiting.iter().collect();
    order.sort_by(|a, b| {
        b.status
            .priority
            .cmp(&a.status.priority)
            .then(a.status.seq.cmp(&b.status.seq))
    });
    let mut taken = vec![false; free.len()];
    let mut out = Vec::new();
    for task in order {
        let best = free
            .iter()
            .enumerate()
            .filter(|(k, r)| {
                !taken[*k]
                    && task.robot.is_none_or(|p| p == r.name)
                    && !task.status.tried.contains(&r.name)
            })
            .filter_map(|(k, r)| length(r, &task.status.to).map(|d| (d, &r.name, k)))
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(b.1)));
        if let Some((_, name, k)) = best {
            taken[k] = true;
            out.push((task.status.id.clone(), name.clone()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn status(id: &str, to: &str, priority: i64, seq: u64) -> TaskStatus {
        TaskStatus::queued(id, to, priority, 0, seq)
    }

    fn free(name: &str, at: &str) -> Free {
        Free {
            name: name.into(),
            at: at.into(),
            at_mm: None,
        }
    }

    /// Positions on a line: the distance is the difference of the numbers.
    fn line(a: &Free, b: &str) -> Option<f64> {
        let n = |s: &str| s.parse::<f64>().ok();
        Some((n(&a.at)? - n(b)?).abs())
    }

    fn wait(s: &TaskStatus) -> Waiting<'_> {
        Waiting {
            status: s,
            robot: None,
        }
    }

    #[test]
    fn the_nearest_free_robot_takes_the_task() {
        let t = status("T1", "10", 0, 1);
        let got = assign(&[wait(&t)], &[free("r1", "0"), free("r2", "12")], line);
        assert_eq!(got, vec![("T1".into(), "r2".into())]);
    }

    #[test]
    fn higher_priority_chooses_first_and_each_robot_takes_one_task() {
        let low = status("T1", "10", 0, 1);
        let high = status("T2", "11", 5, 2);
        let got = assign(
            &[wait(&low), wait(&high)],
            &[free("r1", "0"), free("r2", "12")],
            line,
        );
        assert_eq!(
            got,
            vec![("T2".into(), "r2".into()), ("T1".into(), "r1".into())]
        );
    }

    #[test]
    fn a_pinned_task_waits_for_its_robot_and_a_tried_robot_is_passed_over() {
        let pinned = status("T1", "10", 0, 1);
        let mut tried = status("T2", "10", 0, 2);
        tried.tried.push("r2".into());
        let waiting = [
            Waiting {
                status: &pinned,
                robot: Some("r9"),
            },
            wait(&tried),
        ];
        let got = assign(&waiting, &[free("r1", "0"), free("r2", "10")], line);
        assert_eq!(got, vec![("T2".into(), "r1".into())]);
    }

    #[test]
    fn a_goal_no_route_reaches_is_given_to_no_one() {
        let t = status("T1", "nowhere", 0, 1);
        assert!(assign(&[wait(&t)], &[free("r1", "0")], line).is_empty());
    }
}

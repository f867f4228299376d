//! Tests of `soak`.

use super::*;

#[test]
fn overlap_counts_only_the_holds_the_server_stood_behind() {
    let t0 = Instant::now();
    let at = |ms: u64| t0 + Duration::from_millis(ms);
    let hold = |a, b, revoked| Hold {
        start: at(a),
        end: at(b),
        revoked,
    };
    // Two at once, then a third while both still hold.
    let holds = [
        hold(0, 100, false),
        hold(50, 150, false),
        hold(60, 70, false),
    ];
    assert_eq!(deepest_overlap(&holds), 3);
    // The third had been taken back: not a duplicate.
    let holds = [
        hold(0, 100, false),
        hold(50, 150, false),
        hold(60, 70, true),
    ];
    assert_eq!(deepest_overlap(&holds), 2);
    // A unit handed straight on is not two holders.
    let holds = [hold(0, 100, false), hold(100, 200, false)];
    assert_eq!(deepest_overlap(&holds), 1);
}

#[test]
fn a_failed_run_is_explained_by_its_first_reason_or_its_error() {
    let out = "No. Robot Path\n1 r1 350R to 376L ...\n* r1: L (goal 1, subpath 1): ended on distance alone\n* r1: D (goal 2, subpath 1): stopped 29.82 m from its goal\ndone: 2 goal(s); ground truth puts r1 29.82 m from 376L\n";
    assert_eq!(
        reason(out, "").as_deref(),
        Some("* r#: L (goal #, subpath #): ended on distance alone")
    );
    let err = "rome planner: waiting\nerror: the Navigator has been silent for 30.2s\n";
    assert_eq!(
        reason("plan 350R -> 376L\n", err).as_deref(),
        Some("error: the Navigator has been silent for ##.#s")
    );
    assert_eq!(reason("plan 350R -> 376L\n", "killed\n"), None);
}

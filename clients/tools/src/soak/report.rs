//! The soak's summary as a person reads it (`--json` prints the same
//! figures as JSON).

use super::*;

pub(super) fn print_summary(s: &Summary) {
    println!("soak of {:.1} minutes; logs in {}", s.minutes, s.logs);
    println!("\nfaults thrown:");
    for (k, n) in &s.faults {
        println!("  {k:<18} {n}");
    }
    println!(
        "\nwrites: {} acknowledged, {} failed (not acknowledged); lost: {}",
        s.writes_acked,
        s.writes_failed,
        if s.writes_lost.is_empty() {
            "none".to_string()
        } else {
            s.writes_lost.join("; ")
        }
    );
    println!(
        "semaphore: {} units, {} grants, at most {} holders at once ({} holds taken back by the server when their owner seemed gone); at the end {}",
        s.units, s.waits_granted, s.most_holders, s.holds_revoked, s.semaphore_at_end
    );
    let worst = |v: &[u64]| v.iter().max().copied().unwrap_or(0);
    println!(
        "base lock held by a killed client: released {} times, within {} ms at worst; a robot whose navigator was killed while driving: stopped {} times, within {} ms at worst (bound {} ms for both); {} not seen (the robot's world was down), {} locks not taken in time",
        s.lock_releases_ms.len(),
        worst(&s.lock_releases_ms),
        s.stops_ms.len(),
        worst(&s.stops_ms),
        LOCK_BOUND.as_millis(),
        s.releases_unseen,
        s.locks_not_taken
    );
    let r = &s.runs;
    let judged = r.arrived + r.failed_with_reason + r.failed_without_reason;
    println!(
        "navigation runs: {} of {judged} arrived within {ARRIVED_WITHIN_M} m by ground truth ({:.0} %; worst {:.2} m; {} with no truth to ask), {} failed with a reason, {} failed without one; apart: {} killed by the soak, {} cut short by the end",
        r.arrived,
        100.0 * r.arrived as f64 / judged.max(1) as f64,
        r.worst_miss_m,
        r.arrived_unjudged,
        r.failed_with_reason,
        r.failed_without_reason,
        r.killed_by_soak,
        r.cut_short_by_end
    );
    for (why, n) in &r.reasons {
        println!("  {n} × {why}");
    }
    for f in &s.failures {
        println!("FAILED: {f}");
    }
    println!("{}", if s.passed { "PASSED" } else { "FAILED" });
}

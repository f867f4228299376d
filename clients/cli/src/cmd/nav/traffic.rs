//! The traffic flags of every command that drives robots on a map
//! (`rome planner`, `rome demo`, `rome fleet`), defined once so that they
//! read the same everywhere (docs/traffic.md).

/// How robots keep out of each other's way beyond narrow passages, which
/// are always reserved.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct TrafficArgs {
    /// Reserve the junctions robots turn in, not only narrow passages
    /// (not yet better at high density).
    #[arg(long)]
    pub traffic: bool,
    /// Drive corridors too narrow to pass in one way at a time: wait
    /// outside for robots going the other way to leave. Without it robots
    /// meet head on there and pass keeping right.
    #[arg(long)]
    pub lanes: bool,
    /// Drive the narrow corridors that lie on loops one way only, each its
    /// own way, and plan routes that keep to it; every robot of a fleet
    /// and its dispatcher must agree on it.
    #[arg(long)]
    pub one_way: bool,
    /// With tasks: a robot waiting for one where no walls stand beside it (a task's
    /// goal in a junction) drives on into a corridor before it steps aside
    /// (not yet better in fleets).
    #[arg(long)]
    pub leave_junctions: bool,
    /// With tasks: a robot held up asks the nearest robot standing idle in
    /// its way to make way, and one asked drives on (better in EB3's
    /// fleets, worse in the Campus's: docs/tasks.md).
    #[arg(long)]
    pub make_way: bool,
    /// With tasks: a robot between tasks waits where its task ended even
    /// within 1.5 m of another waiting robot, as it did before; without
    /// it, it drives on to stand apart first (docs/tasks.md, "Waiting
    /// apart").
    #[arg(long)]
    pub wait_side_by_side: bool,
}

impl TrafficArgs {
    /// The rules the flags set.
    pub fn to_rules(&self) -> rome_nav::traffic::Rules {
        rome_nav::traffic::Rules {
            traffic: self.traffic,
            lanes: self.lanes,
            one_way: self.one_way,
            leave_open: self.leave_junctions,
            make_way: self.make_way,
            stand_apart: !self.wait_side_by_side,
        }
    }

    /// Refuses the flags that say what a robot does between tasks, for a
    /// command whose robots take none.
    pub fn without_tasks(&self) -> anyhow::Result<()> {
        anyhow::ensure!(!self.leave_junctions, LEAVE_WITHOUT_TASKS);
        anyhow::ensure!(!self.make_way, MAKE_WAY_WITHOUT_TASKS);
        anyhow::ensure!(!self.wait_side_by_side, SIDE_BY_SIDE_WITHOUT_TASKS);
        Ok(())
    }
}

/// Why `--make-way` is refused where no robot takes tasks.
pub const MAKE_WAY_WITHOUT_TASKS: &str = "--make-way says what a robot does between tasks, \
     so it goes with tasks (rome planner --tasks, rome fleet)";

/// Why `--wait-side-by-side` is refused where no robot takes tasks.
pub const SIDE_BY_SIDE_WITHOUT_TASKS: &str = "--wait-side-by-side says where a robot waits \
     between tasks, so it goes with tasks (rome planner --tasks, rome fleet)";

/// Why `--leave-junctions` is refused where no robot takes tasks: it
/// says where a robot stands between tasks, and a route has none.
pub const LEAVE_WITHOUT_TASKS: &str = "--leave-junctions says where a robot waits between tasks, \
     so it goes with tasks (rome planner --tasks, rome fleet); a route from --from to --to \
     has no wait between tasks";

#[cfg(test)]
mod tests {
    use super::TrafficArgs;
    use clap::Parser;

    #[derive(Parser)]
    struct Cmd {
        #[command(flatten)]
        rules: TrafficArgs,
    }

    fn parse(flags: &[&str]) -> TrafficArgs {
        Cmd::parse_from(std::iter::once("rome").chain(flags.iter().copied())).rules
    }

    #[test]
    fn no_flags_are_the_default_rules_and_each_flag_sets_its_own() {
        assert_eq!(parse(&[]).to_rules(), rome_nav::traffic::Rules::default());
        let r = parse(&["--traffic", "--one-way", "--wait-side-by-side"]).to_rules();
        assert!(r.traffic && r.one_way && !r.stand_apart);
        assert!(!r.lanes && !r.leave_open && !r.make_way);
        let r = parse(&["--lanes", "--leave-junctions", "--make-way"]).to_rules();
        assert!(r.lanes && r.leave_open && r.make_way && r.stand_apart);
    }

    #[test]
    fn flags_for_between_tasks_are_refused_without_tasks_and_say_why() {
        assert!(parse(&["--traffic", "--lanes", "--one-way"])
            .without_tasks()
            .is_ok());
        for flag in ["--leave-junctions", "--make-way", "--wait-side-by-side"] {
            let e = parse(&[flag]).without_tasks().unwrap_err().to_string();
            assert!(e.starts_with(flag), "{flag}: {e}");
        }
    }
}

//! `rome colony`: colony-style networks (§4.8.2) as prioritised clients.
//!
//! ```text
//! rome colony priorities fig4_14a          # a built-in network: fig4_14a, fig4_14b, fig3_9
//! rome colony priorities my.colony         # a network file (format in docs/colony.md)
//! ```
//!
//! It prints each module's priority (1 the lowest, as a forward traversal
//! of Table 4.2's binary tree visits them), the client priority to give
//! each module's process (`rome --priority` or `RobotOptions::priority`),
//! and the equivalent if/else program. Exits with 1 on a malformed network.

use anyhow::Context;
use rome_colony::Priorities;

/// `rome colony` subcommands.
#[derive(Debug, clap::Subcommand)]
pub enum ColonyCmd {
    /// Print each module's priority and the equivalent if/else program.
    Priorities {
        /// A network file, or a built-in network: fig4_14a, fig4_14b, fig3_9.
        network: String,
    },
}

/// Runs a `rome colony` subcommand.
pub fn run(cmd: ColonyCmd) -> anyhow::Result<u8> {
    let ColonyCmd::Priorities { network } = cmd;
    let (file, text) = match rome_colony::builtin::text(&network) {
        Some(t) => (format!("{network} (built in)"), t.to_string()),
        None => (
            network.clone(),
            std::fs::read_to_string(&network)
                .with_context(|| format!("cannot read the network file {network}"))?,
        ),
    };
    let net = rome_colony::parse(&file, &text)?;
    let p = net.priorities();
    let n = p.modules.len();
    println!(
        "{file}: {} module(s), output '{}'; priority 1 is the lowest",
        net.modules().len(),
        net.output_node()
    );
    println!("{:>8}  {:>15}  module", "priority", "client priority");
    for g in &p.modules {
        println!(
            "{:>8}  {:>15}  {}",
            g.priority,
            Priorities::client_priority(g.priority, n),
            g.module
        );
    }
    let silent: Vec<&String> = net.modules().iter().filter(|m| p.of(m).is_none()).collect();
    if !silent.is_empty() {
        println!(
            "only inhibit, never drive the output (Lemma 4.1: their predicates gate the modules they inhibit): {}",
            silent.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(", ")
        );
    }
    println!(
        "\nequivalent program, highest priority first:\n\n{}",
        p.program()
    );
    Ok(0)
}

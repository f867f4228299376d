//! Colony-style networks (Connell's subsumption architecture, thesis
//! §3.2.2 and §4.8.2) emulated by client priorities: each module becomes a
//! client of a hardware server, and the server's priority queue lets the
//! higher module's commands through.
//!
//! How this crate is laid out:
//! - [`parse`]: the text format of a network (modules, suppressor and
//!   inhibitor nodes, the output node) and its checks: cycles, a node
//!   feeding two inputs, a node that reaches no output, unknown names.
//! - [`Network`]: a checked network. [`Network::output`] evaluates it as
//!   the wires would, for given predicates; [`Network::priorities`] removes
//!   the inhibitors by Lemma 4.1 (A ⊗ B becomes C(¬P_A ∧ P_B, φ_B), with
//!   P of a subnetwork as its nodes combine them: [`Pred`]), builds
//!   the binary tree of Table 4.2 (a suppressor's dominant input its right
//!   child, its inferior input its left) and numbers the modules in the
//!   order a forward traversal visits them: first visited, lowest priority
//!   (Lemma 4.2).
//! - [`Priorities`]: each module's priority and applicability predicate
//!   after the inhibitors are gone; [`Priorities::serve`] picks the
//!   highest applicable module, as the server's queue does, and
//!   [`Priorities::program`] prints the equivalent if/else program.
//! - [`behaviours`]: the running example's modules (wander, avoid,
//!   escape) as predicate and transfer function over a base's senses, for
//!   `rome colony behave`.
//!
//! Text format, one statement a line, `#` comments:
//!
//! ```text
//! module A                 # a module M(P_M, φ_M)
//! suppress s1 A over B     # s1's dominant input is A, its inferior input B
//! inhibit i1 C over s1     # C, when it produces output, silences s1
//! output i1                # the node driving the actuators
//! ```

pub mod behaviours;

use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

/// What a node of the network is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Node {
    /// A module M(P, φ).
    Module,
    /// A suppressor: the dominant input's output when it has one, else the
    /// inferior's.
    Suppress {
        /// The dominant input.
        dominant: String,
        /// The inferior input.
        inferior: String,
    },
    /// An inhibitor: nothing while the dominant input has output, else the
    /// inferior's.
    Inhibit {
        /// The input that silences.
        dominant: String,
        /// The input silenced.
        inferior: String,
    },
}

/// A malformed network, with the line it was found on where there is one.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ColonyError {
    /// A line that is no statement.
    #[error("{file}:{line}: {message}")]
    Syntax {
        /// The file.
        file: String,
        /// Its line, from 1.
        line: usize,
        /// What was wrong.
        message: String,
    },
    /// The statements make no network.
    #[error("{file}: {message}")]
    Invalid {
        /// The file.
        file: String,
        /// What was wrong.
        message: String,
    },
}

/// A checked colony-style network.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Network {
    nodes: BTreeMap<String, Node>,
    /// Modules in the order declared.
    modules: Vec<String>,
    output: String,
}

/// When a subnetwork produces output, in terms of its modules'
/// applicability predicates.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Pred {
    /// P_M: module M applies.
    Module(String),
    /// A suppressor's: either input produces output.
    Either(Box<Pred>, Box<Pred>),
    /// An inhibitor's: the inferior input produces output and the dominant
    /// does not (Lemma 4.1's ¬P_A ∧ P_B).
    Unless(Box<Pred>, Box<Pred>),
}

impl Pred {
    /// Whether it holds when the modules for which `applies` is true apply.
    pub fn holds(&self, applies: &dyn Fn(&str) -> bool) -> bool {
        match self {
            Pred::Module(m) => applies(m),
            Pred::Either(a, b) => a.holds(applies) || b.holds(applies),
            Pred::Unless(a, b) => !a.holds(applies) && b.holds(applies),
        }
    }
}

impl fmt::Display for Pred {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Pred::Module(m) => write!(f, "P_{m}(x)"),
            Pred::Either(a, b) => write!(f, "({a} ∨ {b})"),
            Pred::Unless(a, b) => write!(f, "(¬{a} ∧ {b})"),
        }
    }
}

/// A module's place after the inhibitors are gone: its priority, and the
/// subnetworks whose output silences it (Lemma 4.1: it applies only while
/// none of them produces output).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Gated {
    /// The module.
    pub module: String,
    /// Its priority: 1 for the first visited, the lowest.
    pub priority: usize,
    /// The inhibiting subnetworks' predicates.
    pub unless: Vec<Pred>,
}

/// Every module's priority, highest first, with its gating.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Priorities {
    /// Highest priority first.
    pub modules: Vec<Gated>,
}

/// Parses and checks a network; `file` names it in errors.
pub fn parse(file: &str, text: &str) -> Result<Network, ColonyError> {
    let syntax = |line: usize, message: String| ColonyError::Syntax {
        file: file.to_string(),
        line,
        message,
    };
    let invalid = |message: String| ColonyError::Invalid {
        file: file.to_string(),
        message,
    };
    let mut nodes: BTreeMap<String, Node> = BTreeMap::new();
    let mut modules = Vec::new();
    let mut output: Option<(usize, String)> = None;
    let mut defined_at: BTreeMap<String, usize> = BTreeMap::new();
    for (i, raw) in text.lines().enumerate() {
        let n = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        if line.is_empty() {
            continue;
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        let (name, node) = match words[..] {
            ["module", name] => (name, Node::Module),
            ["suppress", name, d, "over", inf] => (
                name,
                Node::Suppress {
                    dominant: d.into(),
                    inferior: inf.into(),
                },
            ),
            ["inhibit", name, d, "over", inf] => (
                name,
                Node::Inhibit {
                    dominant: d.into(),
                    inferior: inf.into(),
                },
            ),
            ["output", name] => {
                if let Some((at, _)) = &output {
                    return Err(syntax(n, format!("a second output (the first is on line {at})")));
                }
                output = Some((n, name.to_string()));
                continue;
            }
            _ => {
                return Err(syntax(
                    n,
                    format!("expected 'module NAME', 'suppress NAME A over B', 'inhibit NAME A over B' or 'output NAME', got '{line}'"),
                ))
            }
        };
        if !name
            .chars()
            .all(|c| c.is_alphanumeric() || c == '_' || c == '-' || c == '.')
        {
            return Err(syntax(
                n,
                format!("'{name}' is no name (letters, digits, _ - .)"),
            ));
        }
        if let Some(at) = defined_at.get(name) {
            return Err(syntax(
                n,
                format!("'{name}' is defined twice (first on line {at})"),
            ));
        }
        if let Node::Suppress { dominant, inferior } | Node::Inhibit { dominant, inferior } = &node
        {
            if dominant == inferior {
                return Err(syntax(
                    n,
                    format!("'{name}' has '{dominant}' on both inputs"),
                ));
            }
        }
        defined_at.insert(name.to_string(), n);
        if node == Node::Module {
            modules.push(name.to_string());
        }
        nodes.insert(name.to_string(), node);
    }
    let (_, output) = output
        .ok_or_else(|| invalid("no 'output NAME': which node drives the actuators?".into()))?;
    if !nodes.contains_key(&output) {
        return Err(invalid(format!("the output '{output}' is not defined")));
    }
    // Every input names a node, and feeds one input only.
    let mut fed: BTreeMap<&str, &str> = BTreeMap::new();
    for (name, node) in &nodes {
        if let Node::Suppress { dominant, inferior } | Node::Inhibit { dominant, inferior } = node {
            for input in [dominant, inferior] {
                if !nodes.contains_key(input) {
                    return Err(invalid(format!(
                        "'{name}' takes '{input}', which is not defined"
                    )));
                }
                if input == &output {
                    return Err(invalid(format!("the network has a cycle: '{name}' takes the output node '{output}' as an input")));
                }
                if let Some(other) = fed.insert(input, name) {
                    return Err(invalid(format!(
                        "'{input}' feeds two inputs, '{other}' and '{name}': a module's output goes to one node"
                    )));
                }
            }
        }
    }
    // From the output every node is reached once: a node reached twice is a
    // cycle, one never reached dangles.
    let mut seen = BTreeSet::new();
    let mut stack = vec![output.clone()];
    while let Some(name) = stack.pop() {
        if !seen.insert(name.clone()) {
            return Err(invalid(format!("the network has a cycle through '{name}'")));
        }
        if let Some(Node::Suppress { dominant, inferior } | Node::Inhibit { dominant, inferior }) =
            nodes.get(&name)
        {
            stack.push(dominant.clone());
            stack.push(inferior.clone());
        }
    }
    // The top of a dangling subnetwork (a node feeding nothing) is named
    // first: that is where a connection is missing.
    let mut dangling: Vec<&String> = nodes.keys().filter(|k| !seen.contains(*k)).collect();
    dangling.sort_by_key(|k| fed.contains_key(k.as_str()));
    if let Some(first) = dangling.first() {
        let what = match nodes.get(*first) {
            Some(Node::Module) => "module",
            Some(Node::Suppress { .. }) => "suppressor",
            _ => "inhibitor",
        };
        return Err(invalid(format!(
            "{what} '{first}' reaches no output{}",
            if dangling.len() > 1 {
                format!(
                    " (nor do {})",
                    dangling[1..]
                        .iter()
                        .map(|s| format!("'{s}'"))
                        .collect::<Vec<_>>()
                        .join(", ")
                )
            } else {
                String::new()
            }
        )));
    }
    Ok(Network {
        nodes,
        modules,
        output,
    })
}

impl Network {
    /// The modules, in the order declared.
    pub fn modules(&self) -> &[String] {
        &self.modules
    }

    /// The node driving the actuators.
    pub fn output_node(&self) -> &str {
        &self.output
    }

    /// What the network puts out when the modules for which `applies` is
    /// true apply: the module whose output reaches the output node, as the
    /// suppressor and inhibitor nodes pass it on.
    pub fn output(&self, applies: &dyn Fn(&str) -> bool) -> Option<String> {
        self.out(&self.output, applies)
    }

    fn out(&self, name: &str, applies: &dyn Fn(&str) -> bool) -> Option<String> {
        match self.nodes.get(name)? {
            Node::Module => applies(name).then(|| name.to_string()),
            Node::Suppress { dominant, inferior } => self
                .out(dominant, applies)
                .or_else(|| self.out(inferior, applies)),
            Node::Inhibit { dominant, inferior } => {
                if self.out(dominant, applies).is_some() {
                    None
                } else {
                    self.out(inferior, applies)
                }
            }
        }
    }

    /// When the subnetwork whose output is `name`'s produces output.
    fn pred(&self, name: &str) -> Pred {
        match self.nodes.get(name) {
            Some(Node::Suppress { dominant, inferior }) => {
                Pred::Either(Box::new(self.pred(dominant)), Box::new(self.pred(inferior)))
            }
            Some(Node::Inhibit { dominant, inferior }) => {
                Pred::Unless(Box::new(self.pred(dominant)), Box::new(self.pred(inferior)))
            }
            _ => Pred::Module(name.to_string()),
        }
    }

    /// The modules of the subnetwork whose output is `name`'s.
    fn modules_under(&self, name: &str, out: &mut Vec<String>) {
        match self.nodes.get(name) {
            Some(Node::Module) => out.push(name.to_string()),
            Some(Node::Suppress { dominant, inferior } | Node::Inhibit { dominant, inferior }) => {
                self.modules_under(dominant, out);
                self.modules_under(inferior, out);
            }
            None => {}
        }
    }

    /// Whether `a` suppresses `b` (a ↓ b): some suppressor has `a` in the
    /// subnetwork on its dominant input and `b` in the one on its inferior
    /// input.
    pub fn suppresses(&self, a: &str, b: &str) -> bool {
        self.nodes.values().any(|n| match n {
            Node::Suppress { dominant, inferior } => {
                let (mut d, mut i) = (Vec::new(), Vec::new());
                self.modules_under(dominant, &mut d);
                self.modules_under(inferior, &mut i);
                d.iter().any(|m| m == a) && i.iter().any(|m| m == b)
            }
            _ => false,
        })
    }

    /// Lemma 4.1 and Table 4.2: the inhibitors removed (each module on an
    /// inhibitor's inferior side gated by ¬P of its dominant side), the
    /// suppressors made the interior nodes of a binary tree (dominant input
    /// the right child, inferior the left), and the modules numbered in the
    /// order a forward (left before right) traversal visits them.
    pub fn priorities(&self) -> Priorities {
        let mut order: Vec<Gated> = Vec::new();
        self.visit(&self.output, &mut Vec::new(), &mut order);
        for (k, g) in order.iter_mut().enumerate() {
            g.priority = k + 1;
        }
        order.reverse();
        Priorities { modules: order }
    }

    fn visit(&self, name: &str, unless: &mut Vec<Pred>, order: &mut Vec<Gated>) {
        match self.nodes.get(name) {
            Some(Node::Module) => order.push(Gated {
                module: name.to_string(),
                priority: 0,
                unless: unless.clone(),
            }),
            Some(Node::Suppress { dominant, inferior }) => {
                self.visit(inferior, unless, order);
                self.visit(dominant, unless, order);
            }
            Some(Node::Inhibit { dominant, inferior }) => {
                // A ⊗ B is C(¬P_A ∧ P_B, φ_B): the dominant side leaves
                // the network, its predicate gates every module of the
                // other side.
                unless.push(self.pred(dominant));
                self.visit(inferior, unless, order);
                unless.pop();
            }
            None => {}
        }
    }
}

impl Priorities {
    /// The module the server serves when the modules for which `applies`
    /// is true send commands: the highest-priority one whose gated
    /// predicate holds.
    pub fn serve(&self, applies: &dyn Fn(&str) -> bool) -> Option<String> {
        self.modules
            .iter()
            .find(|g| applies(&g.module) && !g.unless.iter().any(|p| p.holds(applies)))
            .map(|g| g.module.clone())
    }

    /// The priority of `module`, if it is one of the network's.
    pub fn of(&self, module: &str) -> Option<usize> {
        self.modules
            .iter()
            .find(|g| g.module == module)
            .map(|g| g.priority)
    }

    /// The client priority (as the hardware servers take it, 0–255) for a
    /// module of priority `p` among `n`: spread evenly from 100 for the
    /// lowest to 250 for the highest, so that every higher module is
    /// served first (a lone module gets the default, 128).
    pub fn client_priority(p: usize, n: usize) -> u8 {
        if n <= 1 {
            return 128;
        }
        let step = 150 * (p.clamp(1, n) - 1) / (n - 1);
        u8::try_from(100 + step).unwrap_or(u8::MAX)
    }

    /// The equivalent if/else program (§4.8.2's code segments chained,
    /// highest priority first).
    pub fn program(&self) -> String {
        let mut out = String::new();
        for (k, g) in self.modules.iter().enumerate() {
            let mut cond: Vec<String> = g.unless.iter().map(|p| format!("¬{p}")).collect();
            cond.push(format!("P_{}(x)", g.module));
            let kw = if k == 0 { "if" } else { "else if" };
            out.push_str(&format!(
                "{kw} {} then\n    y := φ_{}(x);\n",
                cond.join(" ∧ "),
                g.module
            ));
        }
        if !self.modules.is_empty() {
            out.push_str("fi\n");
        }
        out
    }
}

impl fmt::Display for Priorities {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for g in &self.modules {
            writeln!(f, "{:>4}  {}", g.priority, g.module)?;
        }
        Ok(())
    }
}

/// The example networks, built in: `fig4_14a` and `fig4_14b` (Figure 4.14).
pub mod builtin {
    /// Figure 4.14, left: `networks/fig4_14a.colony`.
    pub const FIG4_14A: &str = include_str!("../networks/fig4_14a.colony");
    /// Figure 4.14, right: `networks/fig4_14b.colony`.
    pub const FIG4_14B: &str = include_str!("../networks/fig4_14b.colony");
    /// Figure 3.9's shape, with an inhibitor: `networks/fig3_9.colony`.
    pub const FIG3_9: &str = include_str!("../networks/fig3_9.colony");
    /// The running example's three behaviours of one base:
    /// `networks/wander_avoid_escape.colony`.
    pub const WANDER_AVOID_ESCAPE: &str = include_str!("../networks/wander_avoid_escape.colony");

    /// A built-in network's text by name.
    pub fn text(name: &str) -> Option<&'static str> {
        match name {
            "fig4_14a" => Some(FIG4_14A),
            "fig4_14b" => Some(FIG4_14B),
            "fig3_9" => Some(FIG3_9),
            "wander_avoid_escape" => Some(WANDER_AVOID_ESCAPE),
            _ => None,
        }
    }
}

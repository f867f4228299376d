//! Colony-style networks: the Figure 4.14 examples, malformed networks,
//! and random networks checked against Lemma 4.2 and against their wiring.

#![allow(clippy::unwrap_used)]

use rome_colony::{builtin, parse, ColonyError};

fn order(text: &str) -> Vec<String> {
    let p = parse("test", text).unwrap().priorities();
    let mut by_priority: Vec<(usize, String)> = p
        .modules
        .iter()
        .map(|g| (g.priority, g.module.clone()))
        .collect();
    by_priority.sort();
    by_priority.into_iter().map(|(_, m)| m).collect()
}

#[test]
fn both_networks_of_figure_4_14_give_d_c_b_a() {
    for text in [builtin::FIG4_14A, builtin::FIG4_14B] {
        assert_eq!(order(text), ["D", "C", "B", "A"]);
    }
    let p = parse("fig4_14a", builtin::FIG4_14A).unwrap().priorities();
    assert_eq!(p.of("A"), Some(4));
    assert_eq!(p.of("D"), Some(1));
    assert_eq!(
        p.program(),
        "if P_A(x) then\n    y := φ_A(x);\nelse if P_B(x) then\n    y := φ_B(x);\n\
         else if P_C(x) then\n    y := φ_C(x);\nelse if P_D(x) then\n    y := φ_D(x);\nfi\n"
    );
}

#[test]
fn the_running_example_puts_escape_over_avoid_over_wander() {
    use rome_colony::behaviours::Kind;
    let net = parse("wander_avoid_escape", builtin::WANDER_AVOID_ESCAPE).unwrap();
    assert_eq!(
        order(builtin::WANDER_AVOID_ESCAPE),
        ["wander", "avoid", "escape"]
    );
    let p = net.priorities();
    let client: Vec<u8> = ["wander", "avoid", "escape"]
        .iter()
        .map(|m| rome_colony::Priorities::client_priority(p.of(m).unwrap(), 3))
        .collect();
    assert_eq!(client, [100, 175, 250]);
    // Every module is a behaviour `rome colony behave` knows.
    assert!(net.modules().iter().all(|m| Kind::from_name(m).is_some()));
}

#[test]
fn an_inhibitor_gates_the_other_side_by_lemma_4_1() {
    let net = parse("fig3_9", builtin::FIG3_9).unwrap();
    let p = net.priorities();
    assert_eq!(order(builtin::FIG3_9), ["wander", "avoid", "escape"]);
    // `held` only inhibits: it has no priority of its own.
    assert_eq!(p.of("held"), None);
    assert!(
        p.program().starts_with("if ¬P_held(x) ∧ P_escape(x) then"),
        "{}",
        p.program()
    );
    let only = |on: &'static [&'static str]| move |m: &str| on.contains(&m);
    assert_eq!(
        net.output(&only(&["wander", "avoid"])),
        Some("avoid".into())
    );
    assert_eq!(net.output(&only(&["wander", "avoid", "held"])), None);
    assert_eq!(p.serve(&only(&["wander", "avoid", "held"])), None);
    assert_eq!(p.serve(&only(&["wander", "escape"])), Some("escape".into()));
}

fn invalid(text: &str) -> String {
    match parse("bad.colony", text) {
        Err(e @ (ColonyError::Invalid { .. } | ColonyError::Syntax { .. })) => e.to_string(),
        Ok(n) => panic!("accepted: {n:?}"),
    }
}

#[test]
fn malformed_networks_are_refused_with_what_is_wrong() {
    let e =
        invalid("module A\nmodule B\nsuppress s1 A over s2\nsuppress s2 B over s1\noutput s1\n");
    assert!(e.contains("has a cycle"), "{e}");
    let e = invalid(
        "module A\nmodule B\nmodule C\nsuppress s1 A over s2\nsuppress s2 B over s3\nsuppress s3 C over s2\noutput s1\n",
    );
    assert!(e.contains("'s2' feeds two inputs"), "{e}");
    let e = invalid(
        "module A\nmodule B\nmodule C\nsuppress s1 A over B\nsuppress s2 A over C\noutput s2\n",
    );
    assert!(e.contains("'A' feeds two inputs, 's1' and 's2'"), "{e}");
    let e = invalid("module A\nmodule B\nmodule C\nmodule D\nsuppress s1 A over B\nsuppress s2 C over D\noutput s1\n");
    assert!(e.contains("suppressor 's2' reaches no output"), "{e}");
    let e = invalid("module A\nmodule B\nsuppress s1 A over X\noutput s1\n");
    assert!(e.contains("'s1' takes 'X', which is not defined"), "{e}");
    let e = invalid("module A\n");
    assert!(e.contains("no 'output NAME'"), "{e}");
    let e = invalid("module A\nsupress s1 A over B\n");
    assert!(e.starts_with("bad.colony:2: expected"), "{e}");
    let e = invalid("module A\nmodule A\noutput A\n");
    assert!(
        e.contains("bad.colony:2: 'A' is defined twice (first on line 1)"),
        "{e}"
    );
    // A cycle that feeds nothing twice: a loop of two suppressors hanging
    // off nothing but each other is unreachable from the output.
    let e = invalid(
        "module A\nmodule B\nmodule C\nsuppress s1 s2 over A\nsuppress s2 s1 over B\noutput C\n",
    );
    assert!(e.contains("reaches no output"), "{e}");
}

/// A small deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }
    fn below(&mut self, n: u64) -> u64 {
        self.next() % n
    }
}

/// A random network over `mods` as text: every interior node a suppressor
/// or (one time in three) an inhibitor, either input dominant.
fn random_network(rng: &mut Rng, n_modules: usize) -> String {
    fn build(rng: &mut Rng, mods: &[String], out: &mut Vec<String>, next: &mut usize) -> String {
        if mods.len() == 1 {
            return mods[0].clone();
        }
        let k = 1 + rng.below(mods.len() as u64 - 1) as usize;
        let (l, r) = mods.split_at(k);
        let (a, b) = (build(rng, l, out, next), build(rng, r, out, next));
        let (d, i) = if rng.below(2) == 0 { (a, b) } else { (b, a) };
        *next += 1;
        let name = format!("n{next}");
        let kind = if rng.below(3) == 0 {
            "inhibit"
        } else {
            "suppress"
        };
        out.push(format!("{kind} {name} {d} over {i}"));
        name
    }
    let mods: Vec<String> = (0..n_modules).map(|k| format!("m{k}")).collect();
    let mut lines: Vec<String> = mods.iter().map(|m| format!("module {m}")).collect();
    let mut next = 0;
    let root = build(rng, &mods, &mut lines, &mut next);
    lines.push(format!("output {root}"));
    lines.join("\n")
}

#[test]
fn random_networks_agree_with_lemma_4_2_and_with_their_wiring() {
    let mut rng = Rng(42);
    let mut inhibitors = 0;
    for _ in 0..400 {
        let n = 1 + rng.below(9) as usize;
        let text = random_network(&mut rng, n);
        inhibitors += text.matches("inhibit").count();
        let net = parse("random", &text).unwrap();
        let p = net.priorities();
        // (a) Lemma 4.2: a higher priority exactly when it suppresses.
        for a in &p.modules {
            for b in &p.modules {
                if a.module != b.module {
                    assert_eq!(
                        a.priority > b.priority,
                        net.suppresses(&a.module, &b.module),
                        "{} vs {} in\n{text}",
                        a.module,
                        b.module
                    );
                }
            }
        }
        // (b) Serving the applicable modules by priority puts out what the
        // wires do, for random inputs.
        for _ in 0..50 {
            let on: Vec<bool> = (0..n).map(|_| rng.below(2) == 0).collect();
            let applies = |m: &str| on[m[1..].parse::<usize>().unwrap()];
            assert_eq!(
                p.serve(&applies),
                net.output(&applies),
                "inputs {on:?} in\n{text}"
            );
        }
    }
    assert!(
        inhibitors > 100,
        "the generator made few inhibitors: {inhibitors}"
    );
}

//! The confidence automaton of §6.3 (Figures 6.6–6.7, Tables 6.4–6.5):
//! the chance that a route's string of modes reaches its goal, from
//! transition probabilities estimated over runs.
//!
//! States (Table 6.4): S the start, F on a corridor whose first light was
//! found, C in a corner, G at the goal. A route's input string has one
//! symbol per mode as the Navigator goes through them: `l` a
//! light-tracking segment, `c` a corner (entering and leaving it), `d` the
//! last dead-reckoning leg. The transitions and their probabilities:
//!
//! ```text
//! S -l-> F  p1   the first light of the route is found
//! F -c-> C  p2   the light-tracking segment ends well (L-mode), into a corner
//! C -c-> C  p3   a corner right after a corner
//! S -c-> C  p4   a route that starts with a corner
//! C -l-> F  p5   the corner, then the first light of the next corridor
//! F -d-> G  p6   = p2, the last light, then the last leg
//! C -d-> G  p7   a corner, then the last leg
//! ```
//!
//! p2 = p6 is the share of L segments judged successful; p3 = p4 = p7 the
//! share of corners whose entering and leaving both were; p5 = p3 × the
//! share of L segments after a corner whose first light was seen, not
//! counted by distance. A route's confidence is the (S, G) entry of the
//! product of the matrices P(x) of its symbols.

use rome_nav::board::GoalType;
use rome_nav::plan::Plan;
use rome_nav::report::Report;
use std::fmt;

/// A count of successes out of trials, shown as the thesis shows them
/// (`99/101`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Count {
    /// Successes.
    pub ok: usize,
    /// Trials.
    pub of: usize,
}

impl Count {
    /// `ok / of`, or 1 with no trial (nothing seen to fail).
    pub fn ratio(&self) -> f64 {
        if self.of == 0 {
            1.0
        } else {
            self.ok as f64 / self.of as f64
        }
    }

    fn add(&mut self, ok: bool) {
        self.of += 1;
        self.ok += usize::from(ok);
    }
}

impl fmt::Display for Count {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}/{}", self.ok, self.of)
    }
}

/// What the probabilities are estimated from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Routes starting with a light segment whose first light was found (p1).
    pub first_light: Count,
    /// Light segments judged successful (p2 = p6).
    pub l_mode: Count,
    /// Corners entered and left successfully (p3 = p4 = p7).
    pub c_mode: Count,
    /// Light segments after a corner whose first light was seen (p5 / p3).
    pub light_after_corner: Count,
}

/// The thesis' counts (§6.3): p1 taken as 1, L-mode 99/101, C-mode 76/79,
/// the first light after a turn 56/57.
pub const THESIS: Counts = Counts {
    first_light: Count { ok: 1, of: 1 },
    l_mode: Count { ok: 99, of: 101 },
    c_mode: Count { ok: 76, of: 79 },
    light_after_corner: Count { ok: 56, of: 57 },
};

impl Counts {
    /// Counts every mode the runs carried out, judged from what happened.
    /// A mode never reached (the run ended before it) is not counted.
    pub fn of_runs<'a>(reports: impl IntoIterator<Item = &'a Report>) -> Counts {
        let mut c = Counts::default();
        for r in reports {
            let steps = &r.steps;
            for (i, h) in steps.iter().enumerate() {
                let ok = h.failure.is_none();
                match h.step.goal.goal_type {
                    GoalType::L => {
                        c.l_mode.add(ok);
                        let first_seen = h
                            .track
                            .as_ref()
                            .is_some_and(|t| !t.first_missed && t.lights > 0);
                        if i == 0 {
                            c.first_light.add(first_seen);
                        } else if steps[i - 1].step.goal.goal_type == GoalType::C {
                            c.light_after_corner.add(first_seen);
                        }
                    }
                    GoalType::E => {
                        // The corner is done when it was entered and left.
                        let left = steps
                            .get(i + 1)
                            .filter(|n| n.step.goal.goal_type == GoalType::C);
                        c.c_mode
                            .add(ok && left.is_some_and(|n| n.failure.is_none()));
                    }
                    // §6.3's automaton has no elevator rides.
                    GoalType::C | GoalType::D | GoalType::V => {}
                }
            }
        }
        c
    }

    /// p1 … p7.
    pub fn p(&self) -> [f64; 7] {
        let l = self.l_mode.ratio();
        let c = self.c_mode.ratio();
        [
            self.first_light.ratio(),
            l,
            c,
            c,
            c * self.light_after_corner.ratio(),
            l,
            c,
        ]
    }
}

/// The three 4 × 4 matrices P(c), P(d), P(l) over states S, F, C, G.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Matrices {
    /// P(c).
    pub c: [[f64; 4]; 4],
    /// P(d).
    pub d: [[f64; 4]; 4],
    /// P(l).
    pub l: [[f64; 4]; 4],
}

const S: usize = 0;
const F: usize = 1;
const C: usize = 2;
const G: usize = 3;

impl Matrices {
    /// The matrices of Figure 6.7 for the probabilities `p` (p1 … p7).
    pub fn new(p: [f64; 7]) -> Matrices {
        let mut m = Matrices {
            c: [[0.0; 4]; 4],
            d: [[0.0; 4]; 4],
            l: [[0.0; 4]; 4],
        };
        m.l[S][F] = p[0];
        m.c[F][C] = p[1];
        m.c[C][C] = p[2];
        m.c[S][C] = p[3];
        m.l[C][F] = p[4];
        m.d[F][G] = p[5];
        m.d[C][G] = p[6];
        m
    }

    /// The confidence of an input string: the chance of going from S to G
    /// reading it. A symbol other than c, d, l, or a string the automaton
    /// cannot read to the end, gives 0.
    pub fn confidence(&self, input: &str) -> f64 {
        let mut v = [1.0, 0.0, 0.0, 0.0];
        for x in input.chars() {
            let m = match x {
                'c' => &self.c,
                'd' => &self.d,
                'l' => &self.l,
                _ => return 0.0,
            };
            let mut next = [0.0; 4];
            for (i, vi) in v.iter().enumerate() {
                for (j, n) in next.iter_mut().enumerate() {
                    *n += vi * m[i][j];
                }
            }
            v = next;
        }
        v[G]
    }

    /// The three matrices as the thesis prints them, to 4 decimals.
    pub fn show(&self) -> String {
        let mut out = String::new();
        for (name, m) in [("P(c)", &self.c), ("P(d)", &self.d), ("P(l)", &self.l)] {
            out.push_str(name);
            out.push_str(" =\n");
            for row in m {
                let cells: Vec<String> = row
                    .iter()
                    .map(|v| {
                        if *v == 0.0 {
                            "0".into()
                        } else {
                            format!("{v:.4}")
                        }
                    })
                    .collect();
                out.push_str(&format!("    [{}]\n", cells.join("  ")));
            }
        }
        out
    }
}

/// A plan's input string: `l` per light segment, `c` per corner (its
/// entering and leaving), `d` for the last leg. A dead-reckoning leg
/// inside the route is part of the mode around it, as in Figure 6.5.
pub fn input_string(plan: &Plan) -> String {
    let n = plan.steps.len();
    plan.steps
        .iter()
        .enumerate()
        .filter_map(|(i, s)| match s.goal.goal_type {
            GoalType::L => Some('l'),
            GoalType::E => Some('c'),
            GoalType::C | GoalType::V => None,
            GoalType::D => (i + 1 == n).then_some('d'),
        })
        .collect()
}

/// The paths of Table 6.5 with the thesis' input strings and confidences.
pub const TABLE_6_5: [(&str, &str, &str, f64); 4] = [
    ("350R", "376L", "ld", 0.962),
    ("341L", "311R", "lclcl", 0.8412),
    ("NE.men.R", "302R", "clclclccd", 0.6809),
    ("341R", "381R", "lclclclclclclclcd", 0.5110),
];

/// §6.3 for a set of runs, in the thesis' layout: the counts and p1 … p7
/// (beside the thesis'), the matrices of Figure 6.7, and Table 6.5 for
/// every route run (input string, confidence from these runs and from the
/// thesis' probabilities, and the thesis' own figure where it gives one).
pub fn markdown(reports: &[&Report]) -> String {
    let ours = Counts::of_runs(reports.iter().copied());
    let (p, tp) = (ours.p(), THESIS.p());
    let mut s = String::from("| p | Event | Ours | Thesis |\n|---|-------|-----:|-------:|\n");
    let rows = [
        (
            "p1",
            "first light of a route found",
            ours.first_light,
            THESIS.first_light,
            0,
        ),
        ("p2 = p6", "L-mode completed", ours.l_mode, THESIS.l_mode, 1),
        (
            "p3 = p4 = p7",
            "C-mode completed",
            ours.c_mode,
            THESIS.c_mode,
            2,
        ),
        (
            "p5",
            "C-mode, then the next corridor's first light found",
            ours.light_after_corner,
            THESIS.light_after_corner,
            4,
        ),
    ];
    for (name, what, o, t, k) in rows {
        let (po, pt) = (p[k], tp[k]);
        let (o, t) = if k == 4 {
            (format!("p3 × {o} = {po:.4}"), format!("p3 × {t} = {pt:.4}"))
        } else {
            (format!("{o} = {po:.4}"), format!("{t} = {pt:.4}"))
        };
        s.push_str(&format!("| {name} | {what} | {o} | {t} |\n"));
    }
    s.push_str("\nFigure 6.7's matrices from these runs (states S, F, C, G):\n\n```text\n");
    s.push_str(&Matrices::new(p).show());
    s.push_str("```\n\nTable 6.5, every route run:\n\n");
    s.push_str("| Path | Input string | Confidence (ours) | With the thesis' p | Thesis' string | Thesis |\n|------|--------------|------------------:|-------------------:|----------------|-------:|\n");
    let (mo, mt) = (Matrices::new(p), Matrices::new(tp));
    let mut seen: Vec<String> = Vec::new();
    for r in reports {
        let label = r.plan.label();
        if seen.contains(&label) {
            continue;
        }
        seen.push(label.clone());
        let input = input_string(&r.plan);
        let thesis = TABLE_6_5
            .iter()
            .find(|(f, t, _, _)| *f == r.from && *t == r.to)
            .map_or("— | —".to_string(), |(_, _, st, c)| {
                format!("{st} | {c}")
            });
        s.push_str(&format!(
            "| {label} | {input} | {:.4} | {:.4} | {thesis} |\n",
            mo.confidence(&input),
            mt.confidence(&input)
        ));
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_thesis_probabilities_give_figure_6_7_and_table_6_5() {
        let p = THESIS.p();
        assert!((p[1] - 0.9802).abs() < 5e-5, "{p:?}");
        assert!((p[2] - 0.9620).abs() < 5e-5, "{p:?}");
        assert!((p[4] - 0.9451).abs() < 5e-5, "{p:?}");
        let m = Matrices::new(p);
        // 341L to 311R with its last leg (Table 6.5 prints the string
        // without the d, but its product has the third .9802).
        assert!((m.confidence("lclcld") - 0.8412).abs() < 5e-4);
        // The other rows, read through Figure 6.7's matrices, give fewer
        // factors of .962 than Table 6.5's products: one corner start (p4),
        // one corner after a corner (p3), one last leg from a corner (p7).
        let (c, l, k) = (p[2], p[1], p[4]);
        let close = |a: f64, b: f64| (a - b).abs() < 1e-12;
        assert!(close(
            m.confidence("clclclccd"),
            c.powi(3) * k.powi(3) * l.powi(3)
        ));
        assert!(close(
            m.confidence("lclclclclclclclcd"),
            k.powi(7) * l.powi(8) * c
        ));
        // "ld" is p1 p6 = .9802; the thesis prints .962 (p7's value).
        assert!((m.confidence("ld") - 0.9802).abs() < 5e-5);
        // Strings the automaton cannot read have no chance.
        assert_eq!(m.confidence("dl"), 0.0);
        assert_eq!(m.confidence("lx"), 0.0);
        assert_eq!(m.confidence(""), 0.0);
    }
}

//! The barcode-like markers pasted on elevator doors (§5.4.6, Figure 5.11).
//!
//! A marker is N bits between N + 1 black separators, every stripe `p`
//! wide and `q` tall, laid out horizontally so that one camera row crosses
//! them all. A 1 is a black bit: with its two separators it makes a black
//! bar 3p wide. No two 1s stand side by side, so a black bar is p or 3p
//! wide and a white one always p. The thesis used N = 3, p = 3.5 in,
//! q = 6 in, at the camera's height of 53 in; so do we.
//!
//! A map gives an elevator door its marker with the attribute
//! `marker=101` (bits as read from the corridor, left to right). Each
//! elevator of a map has its own code.

use std::fmt;

/// Bits in a code (N).
pub const BITS: usize = 3;
/// Stripes in a marker, separators and bits: 2N + 1.
pub const STRIPES: usize = 2 * BITS + 1;
/// A stripe's width p, mm (3.5 in).
pub const P_MM: f64 = 88.9;
/// A stripe's height q, mm (6 in).
pub const Q_MM: f64 = 152.4;
/// Height of the marker's middle above the floor, mm (53 in: the camera's
/// height, so the marker is in the middle rows of the image).
pub const HEIGHT_MM: f64 = 1_346.2;
/// White paper around the stripes, mm, on every side: two stripes, so a
/// reader sees white all round the stripes (bars that go on, a grille or
/// blinds, have none).
pub const MARGIN_MM: f64 = 2.0 * P_MM;

/// A marker's code: N bits, no two 1s side by side.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Code(u8);

impl Code {
    /// A code from its bits, the first (leftmost) the highest; `None` if
    /// it has more than N bits or two 1s side by side.
    pub fn new(bits: u8) -> Option<Code> {
        (u32::from(bits) < 1 << BITS && bits & (bits >> 1) == 0).then_some(Code(bits))
    }

    /// Every code there is, in order: with N = 3, 000 001 010 100 101.
    pub fn all() -> Vec<Code> {
        (0..1u8 << BITS).filter_map(Code::new).collect()
    }

    /// Its bits, the first (leftmost) the highest.
    pub fn bits(self) -> u8 {
        self.0
    }

    /// Bit `i`, counted from the left.
    pub fn bit(self, i: usize) -> bool {
        i < BITS && self.0 >> (BITS - 1 - i) & 1 == 1
    }

    /// Which of the 2N + 1 stripes are black, left to right.
    pub fn stripes(self) -> [bool; STRIPES] {
        std::array::from_fn(|s| s % 2 == 0 || self.bit(s / 2))
    }

    /// The code whose stripes these are, if they are a marker's: every
    /// separator black.
    pub fn from_stripes(stripes: &[bool; STRIPES]) -> Option<Code> {
        if (0..STRIPES).step_by(2).any(|s| !stripes[s]) {
            return None;
        }
        let bits = (0..BITS).fold(0u8, |acc, i| acc << 1 | u8::from(stripes[2 * i + 1]));
        Code::new(bits)
    }

    /// Whether a point of a door `len` mm wide, `u` mm along it and `z`
    /// mm above the floor, is on the marker's paper, and if so whether it
    /// is black. The marker is centred on the door at [`HEIGHT_MM`].
    pub fn ink(self, len: f64, u: f64, z: f64) -> Option<bool> {
        let du = u - (len - STRIPES as f64 * P_MM) / 2.0;
        let dz = z - (HEIGHT_MM - Q_MM / 2.0);
        let on_paper = (-MARGIN_MM..STRIPES as f64 * P_MM + MARGIN_MM).contains(&du)
            && (-MARGIN_MM..Q_MM + MARGIN_MM).contains(&dz);
        if !on_paper {
            return None;
        }
        let stripe = (du / P_MM).floor();
        let inside = (0.0..STRIPES as f64).contains(&stripe) && (0.0..Q_MM).contains(&dz);
        Some(inside && self.stripes()[stripe as usize])
    }
}

impl fmt::Display for Code {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        (0..BITS).try_for_each(|i| write!(f, "{}", u8::from(self.bit(i))))
    }
}

impl std::str::FromStr for Code {
    type Err = String;

    /// `101`: N binary digits, no two 1s side by side.
    fn from_str(s: &str) -> Result<Code, String> {
        if s.len() != BITS || !s.bytes().all(|b| b == b'0' || b == b'1') {
            return Err(format!(
                "marker '{s}' must be {BITS} binary digits, such as 101"
            ));
        }
        let bits = s.bytes().fold(0u8, |acc, b| acc << 1 | u8::from(b == b'1'));
        Code::new(bits).ok_or_else(|| {
            format!("marker '{s}' has two 1s side by side, which would make one bar of them")
        })
    }
}

/// The marker an edge's `marker=` attribute gives, if it has one.
pub fn of_edge(edge: &crate::model::Edge) -> Option<Result<Code, String>> {
    edge.tags.get("marker").map(|s| s.parse())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn there_are_five_codes_and_each_reads_back_from_its_stripes() {
        let all = Code::all();
        let names: Vec<String> = all.iter().map(Code::to_string).collect();
        assert_eq!(names, ["000", "001", "010", "100", "101"]);
        for code in all {
            assert_eq!(Code::from_stripes(&code.stripes()), Some(code));
            assert_eq!(code.to_string().parse::<Code>(), Ok(code));
        }
        // 100: a bar 3p wide, then white, black, white, black.
        let s = "100".parse::<Code>().map(Code::stripes);
        assert_eq!(s, Ok([true, true, true, false, true, false, true]));
    }

    #[test]
    fn a_bad_code_is_refused_with_the_reason() {
        let e = "110".parse::<Code>().err().unwrap_or_default();
        assert!(e.contains("side by side"), "{e}");
        let e = "10".parse::<Code>().err().unwrap_or_default();
        assert!(e.contains("3 binary digits"), "{e}");
        assert_eq!(Code::new(0b1000), None);
        // A missing separator is no marker.
        let mut s = Code::all()[0].stripes();
        s[2] = false;
        assert_eq!(Code::from_stripes(&s), None);
    }

    #[test]
    fn the_ink_is_centred_on_the_door_at_the_camera_height() {
        let code: Code = "010".parse().unwrap_or(Code(0));
        let (len, mid) = (2_000.0, 1_000.0);
        // The middle stripe of 010 is the bit: black, as are its neighbours.
        assert_eq!(code.ink(len, mid, HEIGHT_MM), Some(true));
        assert_eq!(code.ink(len, mid - P_MM, HEIGHT_MM), Some(true));
        assert_eq!(code.ink(len, mid - 2.0 * P_MM, HEIGHT_MM), Some(false));
        // Above the stripes, on the margin: white paper; beyond it: door.
        assert_eq!(
            code.ink(len, mid, HEIGHT_MM + Q_MM / 2.0 + 10.0),
            Some(false)
        );
        assert_eq!(
            code.ink(len, mid, HEIGHT_MM + Q_MM / 2.0 + MARGIN_MM + 10.0),
            None
        );
        assert_eq!(code.ink(len, 100.0, HEIGHT_MM), None);
    }
}

//! A map in world coordinates: x East, y North, millimetres; headings in
//! degrees with North 0 and West 90 (counter-clockwise), as in the thesis.
//!
//! Points and displacements are nalgebra's ([`Point`], [`Vector`]); a
//! heading is a [`Heading`], which knows the thesis' convention and turns
//! into nalgebra's rotation; a robot's pose is a [`Pose`], the one pose
//! type of the simulator and the navigation clients.

pub use nalgebra::{Isometry2, Point2, UnitComplex, Vector2};

/// A point, mm (x East, y North).
pub type Point = Point2<f64>;

/// A displacement, mm.
pub type Vector = Vector2<f64>;

/// A point from its coordinates, mm.
pub fn pt(x: f64, y: f64) -> Point {
    Point::new(x, y)
}

/// A heading in the thesis' convention: degrees, North 0, West 90
/// (counter-clockwise), East −90. Kept as given; [`Heading::normalized`]
/// brings it into (−180, 180].
#[derive(Debug, Clone, Copy, PartialEq, PartialOrd, Default)]
pub struct Heading(f64);

impl Heading {
    /// North.
    pub const NORTH: Heading = Heading(0.0);

    /// A heading of `deg` degrees (North 0, West 90).
    pub const fn from_deg(deg: f64) -> Heading {
        Heading(deg)
    }

    /// Degrees (North 0, West 90), as given.
    pub const fn deg(self) -> f64 {
        self.0
    }

    /// The same direction in (−180, 180].
    pub fn normalized(self) -> Heading {
        Heading(normalize_deg(self.0))
    }

    /// Turned `deg` degrees counter-clockwise.
    pub fn turned(self, deg: f64) -> Heading {
        Heading(self.0 + deg)
    }

    /// The signed turn from `other` to `self`, degrees in (−180, 180].
    pub fn minus(self, other: Heading) -> f64 {
        normalize_deg(self.0 - other.0)
    }

    /// The unit vector pointing this way.
    pub fn unit(self) -> Vector {
        self.rotation() * Vector::x()
    }

    /// The rotation that takes the x axis (East) to this heading: the
    /// thesis' North 0 is the mathematician's 90°.
    pub fn rotation(self) -> UnitComplex<f64> {
        UnitComplex::new((self.0 + 90.0).to_radians())
    }

    /// The heading of a direction (North for a zero vector).
    pub fn of(v: Vector) -> Heading {
        if v.x == 0.0 && v.y == 0.0 {
            return Heading::NORTH;
        }
        Heading(normalize_deg((-v.x).atan2(v.y).to_degrees()))
    }
}

/// The degrees, with the formatter's width and precision (`{:.0}°`).
impl std::fmt::Display for Heading {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        std::fmt::Display::fmt(&self.0, f)
    }
}

/// Where a robot is and which way it faces: the one pose type of the
/// simulator (truth) and the navigation clients (odometry).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Pose {
    /// Position, mm.
    pub at: Point,
    /// Heading.
    pub heading: Heading,
}

impl Pose {
    /// A pose at (`x`, `y`) mm heading `heading_deg` (North 0, West 90).
    pub fn new(x: f64, y: f64, heading_deg: f64) -> Pose {
        Pose {
            at: Point::new(x, y),
            heading: Heading::from_deg(heading_deg),
        }
    }

    /// Distance between two poses' positions, mm.
    pub fn dist(&self, other: &Pose) -> f64 {
        nalgebra::distance(&self.at, &other.at)
    }

    /// The point `d` mm ahead.
    pub fn ahead(&self, d: f64) -> Point {
        self.at + self.heading.unit() * d
    }

    /// As an isometry: robot frame (x ahead, y to the left) to world.
    pub fn isometry(&self) -> Isometry2<f64> {
        Isometry2::from_parts(self.at.coords.into(), self.heading.rotation())
    }
}

/// Unit vector of a heading in degrees (North 0, West 90).
pub fn direction(heading_deg: f64) -> Vector {
    Heading::from_deg(heading_deg).unit()
}

/// Heading from p towards q, degrees (North 0, West 90).
pub fn heading_to(p: Point, q: Point) -> f64 {
    Heading::of(q - p).deg()
}

/// Normalises an angle to (-180, 180].
pub fn normalize_deg(a: f64) -> f64 {
    let mut a = a % 360.0;
    if a <= -180.0 {
        a += 360.0;
    } else if a > 180.0 {
        a -= 360.0;
    }
    a
}

/// Distance between two points, mm.
pub fn distance(p: Point, q: Point) -> f64 {
    nalgebra::distance(&p, &q)
}

/// How far `p` is from the segment `a`–`b`, mm.
pub fn distance_to_segment(p: Point, a: Point, b: Point) -> f64 {
    let (dx, dy) = (b.x - a.x, b.y - a.y);
    let len2 = dx * dx + dy * dy;
    let t = if len2 == 0.0 {
        0.0
    } else {
        (((p.x - a.x) * dx + (p.y - a.y) * dy) / len2).clamp(0.0, 1.0)
    };
    distance(p, Point::new(a.x + t * dx, a.y + t * dy))
}

/// Where the ray from + t·d meets the segment a + u·dir (0 ≤ u ≤ len):
/// (t, u) with t > 0.
pub fn hit(from: Point, d: Vector, a: Point, dir: Vector, len: f64) -> Option<(f64, f64)> {
    // Solve from + t·d = a + u·dir with 2-D cross products.
    let det = dir.perp(&d);
    if det.abs() < 1e-12 {
        return None;
    }
    let r = a - from;
    let t = dir.perp(&r) / det;
    let u = d.perp(&r) / det;
    (t > 1e-6 && (-1e-6..=len + 1e-6).contains(&u)).then_some((t, u))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: Vector, b: Vector) -> bool {
        (a - b).norm() < 1e-12
    }

    #[test]
    fn headings_follow_the_thesis_north_0_west_90() {
        assert!(close(Heading::from_deg(0.0).unit(), Vector::new(0.0, 1.0)));
        assert!(close(
            Heading::from_deg(90.0).unit(),
            Vector::new(-1.0, 0.0)
        ));
        assert!(close(
            Heading::from_deg(-90.0).unit(),
            Vector::new(1.0, 0.0)
        ));
        assert!(close(
            Heading::from_deg(180.0).unit(),
            Vector::new(0.0, -1.0)
        ));
        for deg in [-179.0, -90.0, -12.5, 0.0, 45.0, 90.0, 180.0] {
            let h = Heading::from_deg(deg);
            assert!((Heading::of(h.unit()).deg() - deg).abs() < 1e-9, "{deg}");
        }
        assert_eq!(heading_to(pt(0.0, 0.0), pt(-5.0, 0.0)), 90.0);
        assert_eq!(
            Heading::from_deg(350.0).minus(Heading::from_deg(10.0)),
            -20.0
        );
        assert_eq!(Heading::from_deg(540.0).normalized().deg(), 180.0);
        assert_eq!(format!("{:.0}°", Heading::from_deg(89.6)), "90°");
    }

    #[test]
    fn a_pose_is_an_isometry_from_the_robot_frame() {
        // Facing West at (1000, 2000): one metre ahead is x = 0.
        let p = Pose::new(1_000.0, 2_000.0, 90.0);
        let ahead = p.isometry() * Point::new(1_000.0, 0.0);
        assert!((ahead - pt(0.0, 2_000.0)).norm() < 1e-9, "{ahead}");
        assert!((p.ahead(1_000.0) - ahead).norm() < 1e-9);
        // The robot's left (robot-frame +y) is South when facing West.
        let left = p.isometry() * Point::new(0.0, 500.0);
        assert!((left - pt(1_000.0, 1_500.0)).norm() < 1e-9, "{left}");
        assert_eq!(p.dist(&Pose::new(1_000.0, 2_003.0, 0.0)), 3.0);
    }
}

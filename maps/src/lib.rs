//! StickRep world maps (§5.1, Appendix A): rings of edges traced with the
//! wall on the left, in a text format a person can write and review.
//!
//! How this crate is laid out:
//! - [`model`]: maps, rings, nodes, edges, links: what a file says.
//! - [`mod@parse`]: text → [`Map`], with `file:line` errors.
//! - [`mod@validate`]: the rules a map must keep (rings close, angles and
//!   lengths agree, names are unique, lights lie on their edge, links are
//!   sound), each broken rule reported with its line.
//! - [`geometry`]: points, headings and poses on nalgebra.
//! - [`mod@world`]: a map turned into world coordinates: wall segments,
//!   doors, ceiling lights, door plates and named positions (`350R`).
//! - [`wire`]: the one place a pose meets the wire's `x_mm`, `y_mm`,
//!   `heading_deg`.
//! - [`route`]: shortest paths between named positions along the
//!   corridors' centre lines.
//! - [`render`]: a picture of the map, as SVG or PNG, optionally with a
//!   route or a trajectory drawn on it; labels in DejaVu Sans.
//! - [`font`]: the 5×7 lettering of the simulated door plates.
//!
//! The format is described in `docs/stickrep.md`; `maps/data/` holds the
//! maps.

pub mod font;
pub mod geometry;
pub mod model;
pub mod parse;
pub mod render;
pub mod route;
pub mod validate;
pub mod wire;
pub mod world;

pub use model::Map;
pub use parse::{parse, ParseError};
pub use route::{Network, Route, RouteError};
pub use validate::{validate, Problem};
pub use world::World;

/// The maps shipped with the project, built into the program so that it
/// runs from any directory: `eb3` (the MSU Engineering Building's third
/// floor), `fig5_3` (Figure 5.3), and two buildings of the project's own
/// making: `annex` (one block of rooms, four corridor widths) and `campus`
/// (a grid of 24 blocks whose corridors cross).
pub mod builtin {
    /// The EB3 reconstruction, `maps/data/eb3.stk`.
    pub const EB3: &str = include_str!("../data/eb3.stk");
    /// The Figure 5.3 building, `maps/data/fig5_3.stk`.
    pub const FIG5_3: &str = include_str!("../data/fig5_3.stk");

    /// Routes for several robots at once on EB3, `maps/data/eb3.routes`.
    pub const EB3_ROUTES: &str = include_str!("../data/eb3.routes");
    /// The Annex, a building of the project's own making,
    /// `maps/data/annex.stk` (written by `maps/tools/annex.py`).
    pub const ANNEX: &str = include_str!("../data/annex.stk");
    /// Routes on the Annex, `maps/data/annex.routes`.
    pub const ANNEX_ROUTES: &str = include_str!("../data/annex.routes");
    /// The Campus, a large floor of the project's own making whose
    /// corridors cross, `maps/data/campus.stk` (written by
    /// `maps/tools/campus.py`).
    pub const CAMPUS: &str = include_str!("../data/campus.stk");
    /// Routes on the Campus, `maps/data/campus.routes`.
    pub const CAMPUS_ROUTES: &str = include_str!("../data/campus.routes");

    /// The text of a built-in map by name.
    pub fn text(name: &str) -> Option<&'static str> {
        match name {
            "eb3" => Some(EB3),
            "fig5_3" => Some(FIG5_3),
            "annex" => Some(ANNEX),
            "campus" => Some(CAMPUS),
            _ => None,
        }
    }

    /// A built-in map's fleet routes (`FROM TO` a line), if it has some.
    pub fn routes(name: &str) -> Option<&'static str> {
        match name {
            "eb3" => Some(EB3_ROUTES),
            "annex" => Some(ANNEX_ROUTES),
            "campus" => Some(CAMPUS_ROUTES),
            _ => None,
        }
    }
}

/// Loads a built-in map by name (`eb3`, `fig5_3`, `annex`, `campus`) or else a map file.
pub fn load_named(name_or_path: &str) -> Result<Map, LoadError> {
    match builtin::text(name_or_path) {
        Some(text) => from_text(format!("{name_or_path} (built in)"), text),
        None => load(std::path::Path::new(name_or_path)),
    }
}

/// Reads, parses and validates a map file; every problem is reported.
pub fn load(path: &std::path::Path) -> Result<Map, LoadError> {
    let text = std::fs::read_to_string(path).map_err(|e| LoadError::Io {
        path: path.display().to_string(),
        detail: e.to_string(),
    })?;
    from_text(path.display().to_string(), &text)
}

/// Parses and validates a map's text; `file` names it in errors.
pub fn from_text(file: String, text: &str) -> Result<Map, LoadError> {
    let map = parse(&file, text).map_err(LoadError::Parse)?;
    let problems = validate(&map);
    if problems.is_empty() {
        Ok(map)
    } else {
        Err(LoadError::Invalid { file, problems })
    }
}

/// Why a map could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum LoadError {
    /// The file could not be read.
    #[error("cannot read {path}: {detail}")]
    Io {
        /// The path.
        path: String,
        /// The OS error.
        detail: String,
    },
    /// The text does not follow the format.
    #[error(transparent)]
    Parse(ParseError),
    /// The map breaks rules of StickRep.
    #[error("{}", problems.iter().map(|p| format!("{file}:{p}")).collect::<Vec<_>>().join("\n"))]
    Invalid {
        /// The file.
        file: String,
        /// Every broken rule.
        problems: Vec<Problem>,
    },
}

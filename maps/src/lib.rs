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
//! - [`building`]: several floors joined by elevators (§5.4.6), and
//!   routes that ride them (`3:350R` → `4:450R`).
//! - [`plane`]: a building's floors side by side on one plane, as the
//!   simulator holds them.
//! - [`font`]: the 5×7 lettering of the simulated door plates.
//! - [`marker`]: the barcode-like markers on elevator doors (Fig. 5.11).
//!
//! The format is described in `docs/stickrep.md`; `maps/data/` holds the
//! maps.

pub mod building;
pub mod font;
pub mod geometry;
pub mod marker;
pub mod model;
pub mod parse;
pub mod plane;
pub mod render;
pub mod route;
pub mod validate;
pub mod wire;
pub mod world;

pub use model::Map;
pub use parse::{parse, ParseError};
pub use route::{Network, OneWay, Route, RouteError};
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

    /// The EB3 tower, `maps/data/tower.bldg`: EB3 and two floors above it
    /// (`maps/data/tower-4.stk`, `tower-5.stk`, written by
    /// `maps/tools/tower.py`), joined by its elevators.
    pub const TOWER: &str = include_str!("../data/tower.bldg");
    /// The tower's fourth floor.
    pub const TOWER_4: &str = include_str!("../data/tower-4.stk");
    /// The tower's fifth floor.
    pub const TOWER_5: &str = include_str!("../data/tower-5.stk");
    /// The Twin, `maps/data/twin.bldg`: the Annex's plan on two floors
    /// (`maps/data/twin-1.stk`, `twin-2.stk`, written by
    /// `maps/tools/annex.py`), joined by two elevators.
    pub const TWIN: &str = include_str!("../data/twin.bldg");
    /// The Twin's first floor.
    pub const TWIN_1: &str = include_str!("../data/twin-1.stk");
    /// The Twin's second floor.
    pub const TWIN_2: &str = include_str!("../data/twin-2.stk");
    /// Routes between the Twin's floors, `maps/data/twin.routes`.
    pub const TWIN_ROUTES: &str = include_str!("../data/twin.routes");
    /// Routes between the tower's floors, `maps/data/tower.routes`.
    pub const TOWER_ROUTES: &str = include_str!("../data/tower.routes");

    /// The text of a built-in building by name (`tower`, `twin`).
    pub fn building(name: &str) -> Option<&'static str> {
        match name {
            "tower" => Some(TOWER),
            "twin" => Some(TWIN),
            _ => None,
        }
    }

    /// The text of a built-in map by name.
    pub fn text(name: &str) -> Option<&'static str> {
        match name {
            "eb3" => Some(EB3),
            "tower-4" => Some(TOWER_4),
            "tower-5" => Some(TOWER_5),
            "twin-1" => Some(TWIN_1),
            "twin-2" => Some(TWIN_2),
            "fig5_3" => Some(FIG5_3),
            "annex" => Some(ANNEX),
            "campus" => Some(CAMPUS),
            _ => None,
        }
    }

    /// A built-in map's fleet routes or building's routes between floors
    /// (`FROM TO` a line), if it has some.
    pub fn routes(name: &str) -> Option<&'static str> {
        match name {
            "eb3" => Some(EB3_ROUTES),
            "annex" => Some(ANNEX_ROUTES),
            "campus" => Some(CAMPUS_ROUTES),
            "tower" => Some(TOWER_ROUTES),
            "twin" => Some(TWIN_ROUTES),
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

/// Whether `name_or_path` names a building (a built-in one, `tower` or
/// `twin`, or a `.bldg` file) rather than one floor's map.
pub fn is_building(name_or_path: &str) -> bool {
    builtin::building(name_or_path).is_some() || name_or_path.ends_with(".bldg")
}

/// Loads a built-in building (`tower`, `twin`), or else a building file.
pub fn load_building_named(name_or_path: &str) -> Result<building::Building, LoadError> {
    if let Some(text) = builtin::building(name_or_path) {
        return building::building_from_text(&format!("{name_or_path} (built in)"), text, |m| {
            load_named(m.strip_suffix(".stk").unwrap_or(m))
        });
    }
    building::load_building(std::path::Path::new(name_or_path))
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
    /// A building's floors or elevators are not sound: every problem, a
    /// line each, `FILE:LINE: message`.
    #[error("{0}")]
    Building(String),
    /// The map breaks rules of StickRep.
    #[error("{}", problems.iter().map(|p| format!("{file}:{p}")).collect::<Vec<_>>().join("\n"))]
    Invalid {
        /// The file.
        file: String,
        /// Every broken rule.
        problems: Vec<Problem>,
    },
}

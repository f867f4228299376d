//! `rome map …`: check and draw StickRep maps. Needs no network.

use crate::exit;
use anyhow::Context;
use clap::Subcommand;
use rome_maps::{render, Network, World};
use std::path::PathBuf;

/// The `rome map` commands.
#[derive(Debug, Subcommand)]
pub enum MapCmd {
    /// Check a map: every problem is printed as FILE:LINE: message (exit 1 if any).
    Check {
        /// The map file, or a built-in map: eb3, annex, campus, fig5_3.
        file: PathBuf,
    },
    /// Draw a map to a PNG or SVG picture (by the output's extension).
    Render {
        /// The map file, or a built-in map: eb3, annex, campus, fig5_3.
        file: PathBuf,
        /// The picture to write: .png or .svg.
        #[arg(short, long, value_name = "OUT")]
        output: PathBuf,
        /// Picture width in pixels.
        #[arg(long, default_value_t = 1600, value_parser = clap::value_parser!(u32).range(200..=20000))]
        width: u32,
        /// Also draw the route between two positions: --route 350R 376L.
        #[arg(long, num_args = 2, value_names = ["FROM", "TO"])]
        route: Option<Vec<String>>,
        /// Positions the drawn route must pass, in order.
        #[arg(long, value_name = "POSITION", requires = "route")]
        via: Vec<String>,
        /// Also draw the junctions robots reserve (docs/traffic.md), each
        /// with its number; with --route, those the route holds in red.
        #[arg(long)]
        junctions: bool,
    },
    /// The shortest route between two positions (door jambs like 350R, or
    /// RING.NODE) along the corridors: length, corners and legs.
    Route {
        /// The map file, or a built-in map: eb3, annex, campus, fig5_3.
        file: PathBuf,
        /// Where to start (350R, 303.second.L, outer.NE …).
        from: String,
        /// Where to go.
        to: String,
        /// Positions the route must pass, in order (repeatable).
        #[arg(long, value_name = "POSITION")]
        via: Vec<String>,
        /// Print every leg.
        #[arg(long)]
        legs: bool,
    },
}

/// Every junction of the map's route network as a dot with its number;
/// those a route between `ends` holds in red.
fn junction_shapes(
    map: &rome_maps::Map,
    world: &World,
    ends: Option<&[String]>,
    via: &[String],
) -> anyhow::Result<Vec<render::Shape>> {
    use rome_nav::traffic::Junctions;
    let network = Network::new(map, world);
    let junctions = Junctions::of(&network);
    let held: Vec<String> = match ends {
        Some([from, to]) => rome_nav::plan::Plan::through(world, &network, from, via, to)?
            .holds
            .into_iter()
            .map(|h| h.semaphore)
            .collect(),
        _ => Vec::new(),
    };
    let mut out = Vec::new();
    for k in 0..junctions.len() {
        let color = if held.contains(&Junctions::semaphore(k)) {
            [200, 30, 30]
        } else {
            [90, 90, 200]
        };
        let at = junctions.centre(k);
        out.push(render::Shape::Dot {
            at,
            radius: 6.0,
            color,
        });
        out.push(render::Shape::Text {
            at,
            text: format!("{k:03}"),
            color,
            size: 1,
        });
    }
    Ok(out)
}

/// A built-in map by name (`eb3`, `fig5_3`) or a map file.
fn load_any(file: &std::path::Path) -> Result<rome_maps::Map, rome_maps::LoadError> {
    rome_maps::load_named(&file.to_string_lossy())
}

fn load(file: &std::path::Path) -> anyhow::Result<(rome_maps::Map, World)> {
    let map = load_any(file).map_err(|e| anyhow::anyhow!("{e}"))?;
    let world = World::from_map(&map);
    Ok((map, world))
}

fn route(
    map: &rome_maps::Map,
    world: &World,
    from: &str,
    via: &[String],
    to: &str,
) -> anyhow::Result<rome_maps::Route> {
    let net = Network::new(map, world);
    let via: Vec<&str> = via.iter().map(String::as_str).collect();
    Ok(world.route(&net, from, &via, to)?)
}

/// Runs a `rome map` command.
pub fn run(cmd: MapCmd) -> anyhow::Result<u8> {
    match cmd {
        MapCmd::Check { file } => match load_any(&file) {
            Ok(map) => {
                let world = World::from_map(&map);
                let nodes: usize = map.rings.iter().map(|r| r.nodes.len()).sum();
                let numbered = map
                    .rings
                    .iter()
                    .flat_map(|r| &r.edges)
                    .filter(|e| e.number.is_some())
                    .count();
                println!(
                    "{}: ok: '{}', {} ring(s), {nodes} nodes, {} lights, {numbered} numbered doors, {} plates, {} links",
                    file.display(),
                    map.name,
                    map.rings.len(),
                    world.lights.len(),
                    world.plates.len(),
                    map.links.len()
                );
                Ok(exit::OK)
            }
            Err(e) => {
                eprintln!("{e}");
                Ok(exit::ERROR)
            }
        },
        MapCmd::Route {
            file,
            from,
            to,
            via,
            legs,
        } => {
            let (map, world) = load(&file)?;
            let r = route(&map, &world, &from, &via, &to)?;
            println!(
                "{}: {:.3} m, {} corner(s), {} leg(s)",
                r.stops.join(" -> "),
                r.length_mm / 1000.0,
                r.turns,
                r.points.len() - 1
            );
            if legs {
                for (i, (a, b, len, heading)) in r.legs().into_iter().enumerate() {
                    println!(
                        "  {:>2}. ({:8.2}, {:8.2}) -> ({:8.2}, {:8.2}) m  {:8.3} m  heading {:6.1}",
                        i + 1,
                        a.x / 1000.0,
                        a.y / 1000.0,
                        b.x / 1000.0,
                        b.y / 1000.0,
                        len / 1000.0,
                        heading
                    );
                }
            }
            Ok(exit::OK)
        }
        MapCmd::Render {
            file,
            output,
            width,
            route: between,
            via,
            junctions,
        } => {
            let (map, world) = load(&file)?;
            let mut overlay = match &between {
                Some(ends) => render::route_shapes(&route(&map, &world, &ends[0], &via, &ends[1])?),
                None => Vec::new(),
            };
            if junctions {
                overlay.extend(junction_shapes(&map, &world, between.as_deref(), &via)?);
            }
            let ext = output
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("")
                .to_ascii_lowercase();
            match ext.as_str() {
                "svg" => std::fs::write(&output, render::svg(&map, &world, width, &overlay))
                    .with_context(|| format!("cannot write {}", output.display()))?,
                "png" => render::raster(&map, &world, width, &overlay)
                    .save(&output)
                    .with_context(|| format!("cannot write {}", output.display()))?,
                other => anyhow::bail!(
                    "cannot tell the picture format from '.{other}'; name the output .png or .svg"
                ),
            }
            println!("wrote {}", output.display());
            Ok(exit::OK)
        }
    }
}

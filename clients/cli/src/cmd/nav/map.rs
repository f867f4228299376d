//! `rome map …`: check, route and draw StickRep maps and buildings of
//! several floors. Needs no network.

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
        /// The map file, or a built-in map: eb3, annex, campus, fig5_3;
        /// or a building (a .bldg file, or the built-in tower).
        file: PathBuf,
    },
    /// Draw a map to a PNG or SVG picture (by the output's extension); a
    /// building to one picture per floor (OUT-FLOOR.png).
    Render {
        /// The map file, or a built-in map: eb3, annex, campus, fig5_3;
        /// or a building (a .bldg file, or the built-in tower).
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
    /// RING.NODE) along the corridors: length, corners and legs. In a
    /// building, positions are FLOOR:POSITION (3:350R) and a route between
    /// floors rides an elevator.
    Route {
        /// The map file, or a built-in map: eb3, annex, campus, fig5_3;
        /// or a building (a .bldg file, or the built-in tower).
        file: PathBuf,
        /// Where to start (350R, 303.second.L, outer.NE …; 4:450R in a building).
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

/// A building's name or file, if the command's FILE is one.
fn building_of(file: &std::path::Path) -> Option<String> {
    let name = file.to_string_lossy();
    rome_maps::is_building(&name).then(|| name.into_owned())
}

/// `rome map check` of a building: each floor's summary and the elevators.
fn check_building(name: &str) -> anyhow::Result<u8> {
    let b = match rome_maps::load_building_named(name) {
        Ok(b) => b,
        Err(e) => {
            eprintln!("{e}");
            return Ok(exit::ERROR);
        }
    };
    println!(
        "{name}: ok: '{}', {} floor(s), {} elevator(s)",
        b.name,
        b.floors.len(),
        b.elevators.len()
    );
    for f in &b.floors {
        println!(
            "  floor {}: {} ({} ring(s), {} positions)",
            f.name,
            f.source,
            f.map.rings.len(),
            f.world.positions.len()
        );
    }
    for e in &b.elevators {
        let floors: Vec<&str> = e
            .floors
            .iter()
            .map(|&k| b.floors[k].name.as_str())
            .collect();
        let marker = b
            .marker(&e.number)
            .map_or("no marker".to_string(), |c| format!("marker {c}"));
        println!(
            "  elevator {}: floors {}, {marker}",
            e.number,
            floors.join(", ")
        );
    }
    Ok(exit::OK)
}

/// `rome map route` through a building: each floor's walk and the ride.
fn route_building(name: &str, from: &str, to: &str, legs: bool) -> anyhow::Result<u8> {
    let b = rome_maps::load_building_named(name).map_err(|e| anyhow::anyhow!("{e}"))?;
    let r = b.route(from, to)?;
    println!(
        "{from} -> {to}: {:.3} m walked{}",
        r.walked_mm() / 1000.0,
        r.ride
            .as_ref()
            .map(|e| format!(", riding elevator {e}"))
            .unwrap_or_default()
    );
    for (k, walk) in &r.walks {
        println!(
            "  floor {}: {}: {:.3} m, {} corner(s)",
            b.floors[*k].name,
            walk.stops.join(" -> "),
            walk.length_mm / 1000.0,
            walk.turns
        );
        if legs {
            print_legs(walk);
        }
    }
    Ok(exit::OK)
}

/// `rome map render` of a building: one picture per floor, the route's
/// walk on each floor it crosses.
fn render_building(
    name: &str,
    output: &std::path::Path,
    width: u32,
    between: Option<&[String]>,
) -> anyhow::Result<u8> {
    let b = rome_maps::load_building_named(name).map_err(|e| anyhow::anyhow!("{e}"))?;
    let route = match between {
        Some([from, to]) => Some(b.route(from, to)?),
        _ => None,
    };
    let stem = output.with_extension("");
    let ext = output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_string();
    for (k, f) in b.floors.iter().enumerate() {
        let overlay = route
            .iter()
            .flat_map(|r| &r.walks)
            .filter(|(floor, _)| *floor == k)
            .flat_map(|(_, walk)| render::route_shapes(walk))
            .collect::<Vec<_>>();
        let out = PathBuf::from(format!("{}-{}.{ext}", stem.display(), f.name));
        write_picture(&f.map, &f.world, width, &overlay, &out)?;
        println!("wrote {} (floor {})", out.display(), f.name);
    }
    Ok(exit::OK)
}

fn print_legs(r: &rome_maps::Route) {
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

/// Writes the map as a PNG or SVG picture, by the output's extension.
fn write_picture(
    map: &rome_maps::Map,
    world: &World,
    width: u32,
    overlay: &[render::Shape],
    output: &std::path::Path,
) -> anyhow::Result<()> {
    let ext = output
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "svg" => std::fs::write(output, render::svg(map, world, width, overlay))
            .with_context(|| format!("cannot write {}", output.display())),
        "png" => render::raster(map, world, width, overlay)
            .save(output)
            .with_context(|| format!("cannot write {}", output.display())),
        other => anyhow::bail!(
            "cannot tell the picture format from '.{other}'; name the output .png or .svg"
        ),
    }
}

/// Runs a `rome map` command. A building (several floors) and one floor's
/// map take the same commands; each arm asks which it was given.
pub fn run(cmd: MapCmd) -> anyhow::Result<u8> {
    match cmd {
        MapCmd::Check { file } if building_of(&file).is_some() => {
            check_building(&file.to_string_lossy())
        }
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
            if building_of(&file).is_some() {
                anyhow::ensure!(via.is_empty(), "--via is for one floor's map; a building's route rides one elevator between FROM and TO");
                return route_building(&file.to_string_lossy(), &from, &to, legs);
            }
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
                print_legs(&r);
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
            if building_of(&file).is_some() {
                anyhow::ensure!(
                    via.is_empty() && !junctions,
                    "--via and --junctions are for one floor's map"
                );
                return render_building(
                    &file.to_string_lossy(),
                    &output,
                    width,
                    between.as_deref(),
                );
            }
            let (map, world) = load(&file)?;
            let mut overlay = match &between {
                Some(ends) => render::route_shapes(&route(&map, &world, &ends[0], &via, &ends[1])?),
                None => Vec::new(),
            };
            if junctions {
                overlay.extend(junction_shapes(&map, &world, between.as_deref(), &via)?);
            }
            write_picture(&map, &world, width, &overlay, &output)?;
            println!("wrote {}", output.display());
            Ok(exit::OK)
        }
    }
}

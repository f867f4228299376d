//! `rome map …`: check and draw StickRep maps. Needs no network.

use crate::exit;
use anyhow::Context;
use clap::Subcommand;
use rome_maps::{render, World};
use std::path::PathBuf;

/// The `rome map` commands.
#[derive(Debug, Subcommand)]
pub enum MapCmd {
    /// Check a map: every problem is printed as FILE:LINE: message (exit 1 if any).
    Check {
        /// The map file.
        file: PathBuf,
    },
    /// Draw a map to a PNG or SVG picture (by the output's extension).
    Render {
        /// The map file.
        file: PathBuf,
        /// The picture to write: .png or .svg.
        #[arg(short, long, value_name = "OUT")]
        output: PathBuf,
        /// Picture width in pixels.
        #[arg(long, default_value_t = 1600, value_parser = clap::value_parser!(u32).range(200..=20000))]
        width: u32,
    },
}

/// Runs a `rome map` command.
pub fn run(cmd: MapCmd) -> anyhow::Result<u8> {
    match cmd {
        MapCmd::Check { file } => match rome_maps::load(&file) {
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
        MapCmd::Render {
            file,
            output,
            width,
        } => {
            let map = rome_maps::load(&file).map_err(|e| anyhow::anyhow!("{e}"))?;
            let world = World::from_map(&map);
            let ext = output
                .extension()
                .and_then(|e| e.to_str())
                .unwrap_or("")
                .to_ascii_lowercase();
            match ext.as_str() {
                "svg" => std::fs::write(&output, render::svg(&map, &world, width))
                    .with_context(|| format!("cannot write {}", output.display()))?,
                "png" => render::raster(&map, &world, width)
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

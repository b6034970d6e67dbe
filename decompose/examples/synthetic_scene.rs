//! Writes the synthetic Lambertian scene and its ground truth as PNGs (development aid):
//! `cargo run --example synthetic_scene -- OUT_DIR`.

use decompose::io::{Depth, Encoding, save};
use decompose::synthetic;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::path::PathBuf::from(std::env::args().nth(1).ok_or("usage: OUT_DIR")?);
    std::fs::create_dir_all(&out)?;
    let g = synthetic::scene(96, 80, 3);
    save(
        out.join("input.png"),
        &g.input,
        Encoding::Srgb,
        Depth::Sixteen,
    )?;
    save(
        out.join("reflectance.png"),
        &g.reflectance,
        Encoding::Srgb,
        Depth::Eight,
    )?;
    save(
        out.join("shading.png"),
        &g.shading,
        Encoding::Srgb,
        Depth::Eight,
    )?;
    Ok(())
}

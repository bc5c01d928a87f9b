//! Measure any remesh against its input with the metric of the `maps` command's summary
//! (`maps::quality::remesh_quality`: exact point-to-triangle distances from a BVH, two-sided
//! sampled Hausdorff and area-weighted mean distances relative to the input's bounding-box
//! diagonal, and the remesh's wrong-facing area), so that a remesh made by another program
//! (the MAPS guide compares SubdivNet's Python MAPS) is judged as reparam's own are.
//!
//! ```sh
//! cargo run --release --example maps_compare -- INPUT REMESH [REMESH …]
//! ```
//!
//! Prints one line per remesh: faces, Hausdorff %, mean %, wrong-facing area % (and its
//! faces). The meshes are OBJ, PLY or OFF files, or `procedural:<name>` for the input.

fn main() -> reparam::Result<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let [input, remeshes @ ..] = args.as_slice() else {
        eprintln!("usage: maps_compare INPUT REMESH [REMESH …]");
        std::process::exit(2);
    };
    let input = reparam::cli::load_maps_input(input)?;
    let (mut lo, mut hi) = (input.positions[0], input.positions[0]);
    for p in &input.positions {
        for a in 0..3 {
            lo[a] = lo[a].min(p[a]);
            hi[a] = hi[a].max(p[a]);
        }
    }
    let diagonal = (hi - lo).norm();
    for path in remeshes {
        let remesh = reparam::mesh::load_mesh(std::path::Path::new(path))?;
        let q = reparam::maps::quality::remesh_quality(
            &remesh.positions,
            &remesh.faces,
            &input.positions,
            &input.faces,
            diagonal,
        );
        println!(
            "{path}: {} faces, Hausdorff {:.3} %, mean {:.4} %, wrong-facing {:.4} % ({} faces)",
            remesh.faces.len(),
            100.0 * q.hausdorff_relative,
            100.0 * q.mean_relative,
            100.0 * q.wrong_facing_area,
            q.wrong_facing.faces
        );
    }
    Ok(())
}

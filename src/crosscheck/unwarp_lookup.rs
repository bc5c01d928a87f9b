//! unwarp cross-check of the `unwarp_lookup` kernel (entry `main`, the render-time lookup
//! s + o(u) through the offset mip chain): the GPU's f32 coordinates against the f64 reference
//! `lookup_coordinate` on the same f32-rounded chain and queries, per component in UV units,
//! held to `lookup_bounds` (written once in `super::unwarp_lookup_bound`); queries whose
//! nearest level f32 cannot decide are counted in the row's note, their bound unbounded.
//!
//! The chain is that of a short reference solve of the map (at most 10 sweeps, no coarse
//! moves); the queries (`lookup_queries`) cover the map on a grid, in the first tile and far
//! from it, at footprints sweeping λ from 0 past the coarsest level.

use reparam_gpu::unwarp::{LookupQuery, OffsetChain, UnwarpLookupKernel};
use reparam_gpu::Gpu;

use super::timing::{time_cpu, time_gpu_warm};
use super::unwarp_lookup_bound::{lookup_bounds, LOOKUP_BOUND_FORMULA};
use super::{Bounds, Row};
use crate::error::{Error, Result};
use crate::unwarp::apply::{lookup_coordinate, Footprint, MipmapFilter, Query};
use crate::unwarp::mesh::Border;
use crate::unwarp::output::{offset_mip_chain, OffsetLevel};
use crate::unwarp::{solve, HeightMap, UnwarpOptions};

fn r32(x: f64) -> f64 {
    x as f32 as f64
}

/// The offset chain of `offsets` (W × H) with every level rounded to f32, as the kernel
/// receives it.
pub fn rounded_chain(width: usize, height: usize, offsets: &[[f64; 2]]) -> Vec<OffsetLevel> {
    let rounded: Vec<[f64; 2]> = offsets.iter().map(|o| o.map(r32)).collect();
    offset_mip_chain(width, height, &rounded)
        .into_iter()
        .map(|l| OffsetLevel {
            offsets: l.offsets.iter().map(|o| o.map(r32)).collect(),
            ..l
        })
        .collect()
}

/// `side`² queries (f32-rounded): coordinates on a grid of the first tile shifted by a
/// tile count that grows with the index (up to 2¹⁶ tiles, negative too), footprints of length
/// 2^λ, λ sweeping 0 … L + 1 over the queries, turning direction.
pub fn lookup_queries(side: usize, levels: usize) -> Vec<Query> {
    let n = side * side;
    (0..n)
        .map(|k| {
            let (i, j) = (k % side, k / side);
            let tile = [
                ((k * 7919) % 65_536) as f64 - 32_768.0,
                ((k * 104_729) % 4_096) as f64 - 2_048.0,
            ];
            let tile = if k % 3 == 0 { [0.0; 2] } else { tile };
            let uv = [
                tile[0] + (i as f64 + 0.31) / side as f64,
                tile[1] + (j as f64 + 0.67) / side as f64,
            ];
            let lambda = (levels + 1) as f64 * k as f64 / n as f64;
            let rho = 2f64.powf(lambda);
            let a = 0.61 * k as f64;
            Query {
                uv: uv.map(r32),
                footprint: Footprint {
                    dx: [r32(rho * a.cos()), r32(rho * a.sin())],
                    dy: [r32(-0.7 * rho * a.sin()), r32(0.7 * rho * a.cos())],
                },
            }
        })
        .collect()
}

/// The kernel's view of a chain.
pub fn gpu_chain(chain: &[OffsetLevel], border: Border, filter: MipmapFilter) -> OffsetChain {
    let mut levels = vec![];
    let mut offsets = vec![];
    for l in chain {
        levels.push([l.width as u32, l.height as u32, offsets.len() as u32]);
        offsets.extend(l.offsets.iter().map(|o| o.map(|c| c as f32)));
    }
    OffsetChain {
        periodic: border == Border::Periodic,
        mipmap_linear: filter == MipmapFilter::Linear,
        levels,
        offsets,
    }
}

/// |GPU − reference| per component; a periodic map's coordinates modulo 1 (a repeating
/// sampler sees no more of them).
pub fn coordinate_error(reference: [f64; 2], got: [f64; 2], border: Border) -> [f64; 2] {
    [0, 1].map(|i| {
        let d = got[i] - reference[i];
        match border {
            Border::Periodic => (d - d.round()).abs(),
            Border::Fixed => d.abs(),
        }
    })
}

/// One row: the chain's lookups on the GPU under `filter` against the reference.
pub fn lookup_row(
    gpu: &Gpu,
    input: &str,
    chain: &[OffsetLevel],
    border: Border,
    filter: MipmapFilter,
    queries: &[Query],
) -> Result<Row> {
    let gpu_error = |e: reparam_gpu::GpuError| Error::Gpu(e.to_string());
    let kernel =
        UnwarpLookupKernel::new(gpu, &gpu_chain(chain, border, filter)).map_err(gpu_error)?;
    let packed: Vec<LookupQuery> = queries
        .iter()
        .map(|q| LookupQuery {
            uv: q.uv.map(|c| c as f32),
            dx: q.footprint.dx.map(|c| c as f32),
            dy: q.footprint.dy.map(|c| c as f32),
        })
        .collect();
    let (got, timing) = time_gpu_warm(gpu, || kernel.lookup(gpu, &packed).map_err(gpu_error))?;
    let (reference, cpu_ms) = time_cpu(|| {
        use rayon::prelude::*;
        queries
            .par_iter()
            .map(|q| lookup_coordinate(chain, border, filter, q))
            .collect::<Vec<_>>()
    });
    let (bounds, undecided) = lookup_bounds(chain, border, filter, queries);
    let errors: Vec<f64> = reference
        .iter()
        .zip(&got)
        .flat_map(|(r, g)| coordinate_error(*r, g.map(f64::from), border))
        .collect();
    let bounds: Vec<f64> = bounds.iter().flatten().copied().collect();
    let name = match filter {
        MipmapFilter::Linear => "unwarp_lookup: coordinate s + o(u), trilinear",
        MipmapFilter::Nearest => "unwarp_lookup: coordinate s + o(u), nearest level",
    };
    Ok(Row::compare(
        "unwarp",
        name,
        input,
        "UV units",
        &errors,
        &[],
        Bounds::PerElement(bounds),
        LOOKUP_BOUND_FORMULA,
    )
    .with_note(&format!(
        "{} queries × 2 components, {} levels, {border:?} border; {undecided} queries \
         undecided (nearest level within f32's uncertainty of a boundary: not judged)",
        queries.len(),
        chain.len()
    ))
    .with_timing(super::Timing {
        cpu_ms: Some(cpu_ms),
        ..timing
    }))
}

/// The lookup rows of one height map: its offsets after a short reference solve (min(sweeps,
/// 10), no coarse moves), their f32 chain, 64² queries, trilinear and nearest.
pub fn lookup_rows(
    gpu: &Gpu,
    input: &str,
    heights: &HeightMap,
    options: &UnwarpOptions,
) -> Result<Vec<Row>> {
    let options = UnwarpOptions {
        sweeps: options.sweeps.min(10),
        tolerance: None,
        coarse_moves: 0,
        ..options.clone()
    };
    let solution = solve(heights, &options, |_| {})?;
    let mesh = &solution.problem.mesh;
    let chain = rounded_chain(mesh.width, mesh.height, &solution.offsets);
    let queries = lookup_queries(64, chain.len());
    [MipmapFilter::Linear, MipmapFilter::Nearest]
        .into_iter()
        .map(|filter| lookup_row(gpu, input, &chain, mesh.border, filter, &queries))
        .collect()
}

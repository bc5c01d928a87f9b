//! Bridge between the f64 texture lookup ([`super::remap`]) and the f32 `gridwarp_lookup`
//! kernel of `reparam-gpu` (seed §6, §8, §10.2): an [`AtlasRemap`] as the kernel's four tables,
//! and the same atlas rounded to f32, which the f64 reference then looks up through, so that a
//! comparison measures the kernel's arithmetic and nothing else.

use reparam_gpu::gridwarp::lookup::{LookupKernel, LookupTables, RoiGrid, RoiRect, AA, NAA};
use reparam_gpu::Gpu;

use super::energy_naa::VertexGrid;
use super::grid::Grid;
use super::rasterize::Roi;
use super::remap::{AtlasRemap, Remap, Warped};
use crate::error::{Error, Result};

fn gpu_error(e: reparam_gpu::GpuError) -> Error {
    Error::Gpu(e.to_string())
}

fn r32(x: f64) -> f64 {
    x as f32 as f64
}

/// The ROI with its bounds rounded to f32 (a UV may lie outside [0, 1]: the kernel takes any
/// rectangle, e.g. a UDIM tile).
pub fn round_roi(r: &Roi) -> Roi {
    Roi {
        u0: r32(r.u0),
        u1: r32(r.u1),
        v0: r32(r.v0),
        v1: r32(r.v1),
    }
}

/// The lookup with every line and vertex rounded to f32; [`Error::InvalidArgument`] if two
/// lines become one.
pub fn round_remap(r: &Remap) -> Result<Remap> {
    let grid = |g: &Grid| {
        Grid::new(
            g.s.iter().map(|&x| r32(x)).collect(),
            g.t.iter().map(|&x| r32(x)).collect(),
        )
    };
    let warped = match &r.warped {
        Warped::Lines(g) => Warped::Lines(grid(g)?),
        Warped::Vertices(v) => Warped::Vertices(VertexGrid {
            points: v.points.iter().map(|p| [r32(p[0]), r32(p[1])]).collect(),
            ..v.clone()
        }),
    };
    Ok(Remap {
        rest: grid(&r.rest)?,
        warped,
        options: r.options,
    })
}

/// The atlas rounded to f32 ([`round_roi`], [`round_remap`]): what the kernel sees.
pub fn round_atlas(a: &AtlasRemap) -> Result<AtlasRemap> {
    Ok(AtlasRemap {
        rois: a
            .rois
            .iter()
            .map(|(roi, remap)| Ok((round_roi(roi), round_remap(remap)?)))
            .collect::<Result<_>>()?,
    })
}

/// The atlas in the kernel's tables (values rounded to f32): ROI k's rest lines ŝ then t̂ at
/// `rest_lines[grids[k].rest ..]`, its warped lines s then t (AA) or vertices P_ab at
/// 2(a·N + b) (NAA) at `warped[grids[k].warped ..]`.
pub fn lookup_tables(a: &AtlasRemap) -> Result<LookupTables> {
    let mut t = LookupTables::default();
    let offset = |v: &Vec<f32>| {
        u32::try_from(v.len())
            .map_err(|_| Error::InvalidArgument("gridwarp_lookup: tables beyond 2³² values".into()))
    };
    for (roi, remap) in &a.rois {
        let f32s = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        let (m, n) = (remap.rest.s.len(), remap.rest.t.len());
        let rest = offset(&t.rest_lines)?;
        let warped = offset(&t.warped)?;
        t.rest_lines.extend(f32s(&remap.rest.s));
        t.rest_lines.extend(f32s(&remap.rest.t));
        let variant = match &remap.warped {
            Warped::Lines(g) => {
                t.warped.extend(f32s(&g.s));
                t.warped.extend(f32s(&g.t));
                AA
            }
            Warped::Vertices(v) => {
                if (v.m, v.n) != (m, n) {
                    return Err(Error::InvalidArgument(format!(
                        "gridwarp_lookup: a {}×{} vertex grid over {m}×{n} rest lines",
                        v.m, v.n
                    )));
                }
                t.warped
                    .extend(v.points.iter().flat_map(|p| [p[0] as f32, p[1] as f32]));
                NAA
            }
        };
        t.rois.push(RoiRect {
            u0: roi.u0 as f32,
            u1: roi.u1 as f32,
            v0: roi.v0 as f32,
            v1: roi.v1 as f32,
        });
        t.grids.push(RoiGrid {
            variant,
            blend: u32::from(remap.options.boundary_blend),
            m: m as u32,
            n: n as u32,
            rest,
            warped,
        });
    }
    Ok(t)
}

/// The kernel's tables as the flat arrays of the conformance vectors (the twin's view).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FlatTables {
    /// u0, u1, v0, v1 per ROI.
    pub rois: Vec<f32>,
    /// variant, blend, M, N, rest offset, warped offset per ROI.
    pub grids: Vec<u32>,
    pub rest_lines: Vec<f32>,
    pub warped: Vec<f32>,
}

impl FlatTables {
    /// Flatten the GPU's tables.
    pub fn of(t: &LookupTables) -> FlatTables {
        FlatTables {
            rois: t
                .rois
                .iter()
                .flat_map(|r| [r.u0, r.u1, r.v0, r.v1])
                .collect(),
            grids: t
                .grids
                .iter()
                .flat_map(|g| [g.variant, g.blend, g.m, g.n, g.rest, g.warped])
                .collect(),
            rest_lines: t.rest_lines.clone(),
            warped: t.warped.clone(),
        }
    }

    /// The GPU's tables again; [`Error::InvalidArgument`] unless there are 4 ROI values and 6
    /// grid values per ROI.
    pub fn to_gpu(&self) -> Result<LookupTables> {
        if !self.rois.len().is_multiple_of(4) || self.grids.len() != 6 * (self.rois.len() / 4) {
            return Err(Error::InvalidArgument(format!(
                "gridwarp_lookup: {} ROI values and {} grid values; need 4 and 6 per ROI",
                self.rois.len(),
                self.grids.len()
            )));
        }
        Ok(LookupTables {
            rois: self
                .rois
                .chunks(4)
                .map(|r| RoiRect {
                    u0: r[0],
                    u1: r[1],
                    v0: r[2],
                    v1: r[3],
                })
                .collect(),
            grids: self
                .grids
                .chunks(6)
                .map(|g| RoiGrid {
                    variant: g[0],
                    blend: g[1],
                    m: g[2],
                    n: g[3],
                    rest: g[4],
                    warped: g[5],
                })
                .collect(),
            rest_lines: self.rest_lines.clone(),
            warped: self.warped.clone(),
        })
    }

    /// [`FlatTables::to_gpu`] and [`LookupTables::check`]: the tables every index of the kernel
    /// (and of its twin) stays inside; the error names the ROI.
    pub fn checked(&self) -> Result<()> {
        self.to_gpu()?.check().map_err(gpu_error)
    }

    /// The twin's view.
    pub fn tables(&self) -> crate::twin::gridwarp_lookup::Tables<'_> {
        crate::twin::gridwarp_lookup::Tables {
            rois: &self.rois,
            grids: &self.grids,
            rest_lines: &self.rest_lines,
            warped: &self.warped,
        }
    }
}

/// `queries` rounded to f32.
pub fn queries_f32(queries: &[[f64; 2]]) -> Vec<[f32; 2]> {
    queries.iter().map(|q| [q[0] as f32, q[1] as f32]).collect()
}

/// The kernel's lookup of every query through `atlas` (its values rounded to f32).
pub fn gpu_lookup_uv(gpu: &Gpu, atlas: &AtlasRemap, queries: &[[f32; 2]]) -> Result<Vec<[f32; 2]>> {
    let tables = lookup_tables(atlas)?;
    LookupKernel::new(gpu, &tables)
        .and_then(|k| k.run(gpu, queries))
        .map_err(gpu_error)
}

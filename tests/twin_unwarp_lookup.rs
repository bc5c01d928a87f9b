//! The f32 twin of `unwarp_lookup` (entry `main`) under the seven arithmetic models against the
//! f64 reference `unwarp::apply::lookup_coordinate`, judged by the bound written once in
//! `crosscheck::unwarp_lookup_bound`: every decided query within its bound under every model,
//! the undecided ones (nearest level within f32's uncertainty of a boundary) counted and
//! present; and six wrong kernels (nearest texel instead of bilinear, the wrong mip level, f32
//! without re-centring, no clamp, axes swapped, the level blend dropped) each rejected.
//!
//! Inputs: a smooth 16² offset map (amplitude 0.02 UV) and its mip chain, rounded to f32 as
//! the kernel receives them; queries on a grid of coordinates in the first tile, near u = 0
//! and 1, negative and 2²⁰ tiles away, at footprints whose λ lies on, just below and just above
//! every level boundary (integers, and halves for the nearest level), past the coarsest.

// `!(e <= b)` is meant: a NaN error counts as over its bound.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use reparam::crosscheck::unwarp_lookup_bound::lookup_bounds;
use reparam::twin::real::floor;
use reparam::twin::unwarp_lookup::{
    choose_levels, level_of_detail, lookup_coordinate, offset_to_uv, recentre, texel_pair,
    texel_point, Bindings, Level, Mode, Query,
};
use reparam::twin::{with_model, Model, Real, F, V2};
use reparam::unwarp::apply::{self, Footprint, MipmapFilter};
use reparam::unwarp::mesh::Border;
use reparam::unwarp::output::{offset_mip_chain, OffsetLevel};

fn r32(x: f64) -> f64 {
    x as f32 as f64
}

/// The f32-rounded chain of a smooth 16² map.
fn chain() -> Vec<OffsetLevel> {
    let n = 16;
    let tau = std::f64::consts::TAU;
    let offsets: Vec<[f64; 2]> = (0..n * n)
        .map(|i| {
            let (x, y) = ((i % n) as f64 / n as f64, (i / n) as f64 / n as f64);
            [
                r32(0.02 * (tau * x).sin() * (tau * 2.0 * y).cos()),
                r32(0.015 * (tau * (x + y)).cos()),
            ]
        })
        .collect();
    offset_mip_chain(n, n, &offsets)
        .into_iter()
        .map(|l| OffsetLevel {
            offsets: l.offsets.iter().map(|o| o.map(r32)).collect(),
            ..l
        })
        .collect()
}

fn queries(levels: usize) -> Vec<apply::Query> {
    let mut lambdas = vec![0.0, 0.3];
    for d in 0..=levels {
        for b in [d as f64, d as f64 + 0.5] {
            lambdas.extend([b - 1e-3, b - 1e-6, b, b + 1e-6, b + 1e-3]);
        }
    }
    let mut uvs = vec![];
    for i in 0..7 {
        for j in 0..5 {
            uvs.push([i as f64 / 6.0 + 0.013, j as f64 / 4.0 - 0.007]);
        }
    }
    uvs.extend([[0.0, 0.0], [1.0, 1.0], [1e-9, 1.0 - 1e-9], [-0.3, -2.7]]);
    uvs.extend([[1_048_576.3, -1_048_575.8], [-262_144.55, 65_536.1]]);
    let mut out = vec![];
    for (k, uv) in uvs.iter().enumerate() {
        for (m, &lambda) in lambdas.iter().enumerate() {
            // ρ = 2^λ along a direction that turns with the query.
            let rho: f64 = 2f64.powf(lambda);
            let angle = 0.37 * (k * lambdas.len() + m) as f64;
            let footprint = Footprint {
                dx: [r32(rho * angle.cos()), r32(rho * angle.sin())],
                dy: [r32(0.5 * rho * angle.sin()), r32(-0.5 * rho * angle.cos())],
            };
            out.push(apply::Query {
                uv: uv.map(r32),
                footprint,
            });
        }
    }
    out
}

fn v2(c: [f64; 2]) -> V2<F> {
    V2::new(F::lit(c[0]), F::lit(c[1]))
}

struct Twin {
    levels: Vec<Level>,
    offsets: Vec<V2<F>>,
}

fn twin_inputs(chain: &[OffsetLevel]) -> Twin {
    let mut levels = vec![];
    let mut offsets = vec![];
    for l in chain {
        levels.push(Level {
            width: l.width as u32,
            height: l.height as u32,
            first: offsets.len() as u32,
        });
        offsets.extend(l.offsets.iter().map(|&o| v2(o)));
    }
    Twin { levels, offsets }
}

fn twin_query(q: &apply::Query) -> Query<F> {
    Query {
        uv: v2(q.uv),
        dx: v2(q.footprint.dx),
        dy: v2(q.footprint.dy),
    }
}

/// A wrong kernel: the twin with one step changed.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Mutant {
    NearestTexel,
    WrongLevel,
    NoRecentring,
    NoClamp,
    AxesSwapped,
    BlendDropped,
}

fn mutant_sample(b: &Bindings<F>, level: u32, uv: V2<F>, m: Mutant) -> V2<F> {
    let l = b.levels[level as usize];
    let periodic = b.mode.periodic || m == Mutant::NoClamp;
    let uv = if m == Mutant::NoRecentring {
        uv
    } else {
        recentre(uv, periodic)
    };
    let uv = if m == Mutant::AxesSwapped {
        V2::new(uv.y, uv.x)
    } else {
        uv
    };
    let p = texel_point(uv, l.width, l.height);
    let (x0, x1, mut fx) = texel_pair(p.x, l.width, periodic);
    let (y0, y1, mut fy) = texel_pair(p.y, l.height, periodic);
    if m == Mutant::NearestTexel {
        fx = floor(fx + F::lit(0.5));
        fy = floor(fy + F::lit(0.5));
    }
    let at = |x: u32, y: u32| b.offsets[(l.first + y * l.width + x) as usize];
    let one = F::lit(1.0);
    let top = at(x0, y0) * (one - fx) + at(x1, y0) * fx;
    let bottom = at(x0, y1) * (one - fx) + at(x1, y1) * fx;
    top * (one - fy) + bottom * fy
}

fn mutant_lookup(b: &Bindings<F>, q: &Query<F>, m: Mutant) -> V2<F> {
    let mut lambda = level_of_detail(q.dx, q.dy);
    if m == Mutant::WrongLevel {
        lambda = lambda + F::lit(1.0);
    }
    let count = b.levels.len() as u32;
    let mut choice = choose_levels(lambda, count, b.mode.mipmap_linear);
    if m == Mutant::BlendDropped {
        choice.weight = F::lit(0.0);
    }
    let fine = mutant_sample(b, choice.fine, q.uv, m);
    let coarse = mutant_sample(b, choice.coarse, q.uv, m);
    let w = choice.weight;
    let o = fine * (F::lit(1.0) - w) + coarse * w;
    let base = if m == Mutant::NoRecentring {
        q.uv
    } else {
        recentre(q.uv, b.mode.periodic)
    };
    base + offset_to_uv(o)
}

/// Per query and component: |f32 − f64| (a periodic map's coordinates compared modulo 1: a
/// repeating sampler sees no more of them), or `None` where either is not finite.
fn errors(reference: &[[f64; 2]], got: &[[f64; 2]], periodic: bool) -> Vec<[f64; 2]> {
    reference
        .iter()
        .zip(got)
        .map(|(r, g)| {
            [0, 1].map(|i| {
                let d = g[i] - r[i];
                if periodic {
                    (d - d.round()).abs()
                } else {
                    d.abs()
                }
            })
        })
        .collect()
}

struct Judged {
    over: usize,
    undecided: usize,
    worst_ratio: f64,
}

fn judge(errors: &[[f64; 2]], bounds: &[[f64; 2]]) -> Judged {
    let mut j = Judged {
        over: 0,
        undecided: 0,
        worst_ratio: 0.0,
    };
    for (e, b) in errors.iter().zip(bounds) {
        if b[0] == f64::MAX {
            j.undecided += 1;
            continue;
        }
        for i in 0..2 {
            if !(e[i] <= b[i]) {
                j.over += 1;
            }
            if e[i] > 0.0 {
                j.worst_ratio = j.worst_ratio.max(e[i] / b[i]);
            }
        }
    }
    j
}

fn run(
    twin: &Twin,
    mode: Mode,
    queries: &[apply::Query],
    model: Model,
    mutant: Option<Mutant>,
) -> Vec<[f64; 2]> {
    let b = Bindings {
        mode,
        levels: &twin.levels,
        offsets: &twin.offsets,
    };
    with_model(model, || {
        queries
            .iter()
            .map(|q| {
                let q = twin_query(q);
                let c = match mutant {
                    None => lookup_coordinate(&b, &q),
                    Some(m) => mutant_lookup(&b, &q, m),
                };
                [c.x.value(), c.y.value()]
            })
            .collect()
    })
}

#[test]
fn every_model_is_within_the_bound_undecided_queries_are_counted_and_six_mutants_fail() {
    let chain = chain();
    let twin = twin_inputs(&chain);
    let queries = queries(chain.len());
    let mutants = [
        Mutant::NearestTexel,
        Mutant::WrongLevel,
        Mutant::NoRecentring,
        Mutant::NoClamp,
        Mutant::AxesSwapped,
        Mutant::BlendDropped,
    ];
    let mut rejected = vec![false; mutants.len()];
    for border in [Border::Periodic, Border::Fixed] {
        for filter in [MipmapFilter::Linear, MipmapFilter::Nearest] {
            let mode = Mode {
                periodic: border == Border::Periodic,
                mipmap_linear: filter == MipmapFilter::Linear,
            };
            let reference: Vec<[f64; 2]> = queries
                .iter()
                .map(|q| apply::lookup_coordinate(&chain, border, filter, q))
                .collect();
            let (bounds, undecided) = lookup_bounds(&chain, border, filter, &queries);
            let periodic = mode.periodic;
            if filter == MipmapFilter::Nearest {
                assert!(
                    undecided > 0,
                    "no query at a nearest boundary was undecided"
                );
            } else {
                assert_eq!(undecided, 0, "trilinear is continuous in λ");
            }
            for model in Model::CHECKED {
                let got = run(&twin, mode, &queries, model, None);
                let j = judge(&errors(&reference, &got, periodic), &bounds);
                println!(
                    "{border:?} {filter:?} {}: {} queries, {undecided} undecided, worst \
                     error/bound {:.3e}, {} over",
                    model.name(),
                    queries.len(),
                    j.worst_ratio,
                    j.over
                );
                assert_eq!(j.over, 0, "{border:?} {filter:?} {}", model.name());
                assert_eq!(j.undecided, undecided);
            }
            for (k, &m) in mutants.iter().enumerate() {
                let got = run(&twin, mode, &queries, Model::Nearest, Some(m));
                let j = judge(&errors(&reference, &got, periodic), &bounds);
                println!(
                    "{border:?} {filter:?} mutant {m:?}: {} over, worst {:.3e}",
                    j.over, j.worst_ratio
                );
                rejected[k] |= j.over > 0;
            }
        }
    }
    for (m, r) in mutants.iter().zip(&rejected) {
        assert!(r, "mutant {m:?} passed every configuration");
    }
}

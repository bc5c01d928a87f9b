//! `unwarp_pass` through its f32 twin (`src/twin/unwarp_pass.rs`, run over the canonical
//! inputs by `reparam::twin::candidate::unwarp_pass`):
//! - under every arithmetic model a conforming GPU may use (correctly rounded, FMA-contracted,
//!   reordered, at the edge of the WGSL table) the canonical vectors accept it;
//! - no bound is 0;
//! - the porting mistakes below (mutants) are all rejected. The printed table is the one in src/vectors/README.md.
#![cfg(feature = "gpu")]

mod common;

use common::mutation::MutationTable;
use reparam::twin::candidate::unwarp_pass::{candidate, Inputs};
use reparam::twin::unwarp_pass::{
    descend_texel, fan_new, flip_free_bracket, line_point, neighbour, node_energy, node_gradient,
    pin_gradient, ternary_search, triangle_geometry, triangles_gradient, unwarp_pass_invocation,
    Bindings, Fan, TexelResult, FLAG_BRACKET, FLAG_MOVED, STENCIL,
};
use reparam::twin::{with_model, Model, Real, F, V2, V3};
use reparam::vectors::verify::{verify_array, VerifyReport};
use reparam::vectors::{Array, KernelVectors};

const ALGORITHM: &str = "unwarp";
const KERNEL: &str = "unwarp_pass";

fn kernel() -> KernelVectors {
    common::canonical::kernel(ALGORITHM, KERNEL)
}

fn inputs(k: &KernelVectors) -> Inputs {
    Inputs::load(&common::canonical::dir(ALGORITHM), k).unwrap()
}

fn judge(k: &KernelVectors, a: &Array) -> VerifyReport {
    verify_array(&common::canonical::dir(ALGORITHM), k, a, "twin").unwrap()
}

// ---------------------------------------------------------------------------------------------
// The mutants' harness: `descend_texel` with its parts replaceable.

type FanFn = fn(&Bindings<F>, u32, u32) -> Fan<F>;
type GradientFn = fn(&Fan<F>, F, V2<F>, V2<F>, F) -> V2<F>;
type BracketFn = fn(&Fan<F>, F, V2<F>, V2<F>, V2<F>) -> V3<F>;
/// A port's body of one invocation (node c).
type Body = fn(&Bindings<F>, usize) -> TexelResult<F>;
/// Where a port reads invocation c's texel: (c, W, H) → (x, y).
type TexelOf = fn(usize, u32, u32) -> (u32, u32);

/// A port of `descend_texel`: its fan, gradient, bracket and texel addressing.
#[derive(Clone, Copy)]
struct Port {
    fan: FanFn,
    gradient: GradientFn,
    bracket: BracketFn,
    texel_of: TexelOf,
}

fn row_major(c: usize, w: u32, _: u32) -> (u32, u32) {
    (c as u32 % w, c as u32 / w)
}

/// The kernel's own parts.
const AS_KERNEL: Port = Port {
    fan: fan_new,
    gradient: node_gradient,
    bracket: flip_free_bracket,
    texel_of: row_major,
};

/// `descend_texel` made of `port`'s parts (with [`AS_KERNEL`] it is the twin's, bit for bit:
/// [`the_harness_with_nothing_changed_is_the_kernel`]).
fn descend_with(port: &Port, b: &Bindings<F>, c: usize) -> TexelResult<F> {
    let p = &b.params;
    let (x, y) = (port.texel_of)(c, p.width, p.height);
    let c = (y * p.width + x) as usize;
    let (o, weight, resolution, theta) = (b.offsets[c], b.pins[c], p.pin_resolution, p.theta);
    let fan = (port.fan)(b, x, y);
    let g = (port.gradient)(&fan, weight, resolution, o, theta);
    let mut result = TexelResult {
        offset: o,
        path: 0,
        flags: 0,
    };
    let finite = g.x.value().is_finite() && g.y.value().is_finite();
    if !finite || (g.x.value() == 0.0 && g.y.value() == 0.0) {
        return result;
    }
    let bracket = (port.bracket)(&fan, weight, resolution, o, g);
    if bracket.z.value() == 0.0 {
        return result;
    }
    result.flags = FLAG_BRACKET;
    let energy = |t: F| node_energy(&fan, weight, resolution, line_point(o, g, t), theta);
    let search = ternary_search(energy, bracket.x, bracket.y);
    result.path = search.path;
    result.flags |= search.steps;
    if energy(search.t).value() < energy(F::lit(0.0)).value() {
        result.offset = line_point(o, g, search.t);
        result.flags |= FLAG_MOVED;
    }
    result
}

fn port_candidate(k: &KernelVectors, port: Port, model: Model) -> Array {
    inputs(k).run(model, |b, c| descend_with(&port, b, c))
}

#[test]
fn the_harness_with_nothing_changed_is_the_kernel() {
    let k = kernel();
    let x = inputs(&k);
    for model in [Model::Nearest, Model::Worst(1)] {
        let b = Bindings {
            params: x.params,
            z: &x.z,
            pins: &x.pins,
            offsets: &x.offsets,
        };
        for &c in &x.active {
            let (harness, twin) = with_model(model, || {
                let (cx, cy) = row_major(c, x.params.width, x.params.height);
                (descend_with(&AS_KERNEL, &b, c), descend_texel(&b, cx, cy))
            });
            assert_eq!(harness.offset.values(), twin.offset.values(), "node {c}");
            assert_eq!((harness.path, harness.flags), (twin.path, twin.flags));
        }
    }
}

// ---------------------------------------------------------------------------------------------
// The mutants

/// A fan whose neighbours and UV edges a port builds its own way: `neighbour_of(b, x, y, k)`
/// and `rel(base, o_n)`, the 3D edge (−d/R, z_c − z_n) as the kernel's; triangle k's geometry
/// from the 3D edges `corners(k)` = (i, j) (the kernel's: (k − 1, k)), its UV edges paired as
/// the kernel pairs them.
fn fan_by(
    b: &Bindings<F>,
    x: u32,
    y: u32,
    neighbour_of: fn(&Bindings<F>, u32, u32, usize) -> usize,
    rel: fn(V2<F>, V2<F>) -> V2<F>,
    corners: fn(usize) -> (usize, usize),
) -> Fan<F> {
    let p = &b.params;
    let resolution = V2::new(F::lit(p.width as f64), F::lit(p.height as f64));
    let c = (y * p.width + x) as usize;
    let mut edges = [V3::splat(F::lit(0.0)); 6];
    let mut rels = [V2::splat(F::lit(0.0)); 6];
    for k in 0..6 {
        let n = neighbour_of(b, x, y, k);
        let base = V2::new(
            -F::lit(STENCIL[k][0] as f64) / resolution.x,
            -F::lit(STENCIL[k][1] as f64) / resolution.y,
        );
        edges[k] = V3::new(base.x, base.y, b.z[c] - b.z[n]);
        rels[k] = rel(base, b.offsets[n]);
    }
    let geometry = std::array::from_fn(|k| {
        let (i, j) = corners(k);
        triangle_geometry(edges[i], edges[j])
    });
    Fan {
        geometry,
        rel: rels,
    }
}

fn kernel_neighbour(b: &Bindings<F>, x: u32, y: u32, k: usize) -> usize {
    neighbour(&b.params, x, y, k)
}

fn kernel_rel(base: V2<F>, o_n: V2<F>) -> V2<F> {
    base - o_n
}

fn kernel_corners(k: usize) -> (usize, usize) {
    ((k + 5) % 6, k)
}

/// rel_k = −d_k/R + o_{n_k}: the neighbour's offset added.
fn neighbour_offset_added(b: &Bindings<F>, x: u32, y: u32) -> Fan<F> {
    fan_by(
        b,
        x,
        y,
        kernel_neighbour,
        |base, o| base + o,
        kernel_corners,
    )
}

/// Neighbours across the border clamped to the map instead of wrapped.
fn clamped_border(b: &Bindings<F>, x: u32, y: u32) -> Fan<F> {
    fn clamped(b: &Bindings<F>, x: u32, y: u32, k: usize) -> usize {
        let (w, h) = (b.params.width as i64, b.params.height as i64);
        let nx = (x as i64 + STENCIL[k][0] as i64).clamp(0, w - 1);
        let ny = (y as i64 + STENCIL[k][1] as i64).clamp(0, h - 1);
        (ny * w + nx) as usize
    }
    fan_by(b, x, y, clamped, kernel_rel, kernel_corners)
}

/// Each triangle's geometry from (P_k, P_{k−1}): its corners in the wrong order (the UV edges
/// kept as the kernel pairs them).
fn corners_swapped(b: &Bindings<F>, x: u32, y: u32) -> Fan<F> {
    fan_by(b, x, y, kernel_neighbour, kernel_rel, |k| (k, (k + 5) % 6))
}

/// The stencil walked clockwise: T_k = (c, n_{k+1}, n_k), every UV triangle reversed.
fn stencil_clockwise(b: &Bindings<F>, x: u32, y: u32) -> Fan<F> {
    let mut fan = fan_new(b, x, y);
    fan.rel.reverse();
    fan
}

/// The 3D edge's height difference dropped (P_k = (−d_k/R, 0)): the flat map's fan.
fn heights_ignored(b: &Bindings<F>, x: u32, y: u32) -> Fan<F> {
    let zero = vec![F::lit(0.0); b.z.len()];
    fan_new(&Bindings { z: &zero, ..*b }, x, y)
}

/// ∇F without the pin barrier's gradient (a term dropped).
fn pin_gradient_dropped(fan: &Fan<F>, _: F, _: V2<F>, o: V2<F>, theta: F) -> V2<F> {
    triangles_gradient(fan, o, theta)
}

/// The step taken along +∇F (the gradient's sign).
fn ascending(fan: &Fan<F>, w: F, r: V2<F>, o: V2<F>, theta: F) -> V2<F> {
    -node_gradient(fan, w, r, o, theta)
}

/// ∇E_pin with the 2 of ∇q = 2 w² R² o dropped.
fn pin_gradient_halved(fan: &Fan<F>, w: F, r: V2<F>, o: V2<F>, theta: F) -> V2<F> {
    triangles_gradient(fan, o, theta) + pin_gradient(w, r, o) * F::lit(0.5)
}

/// Invocation c read as column-major: (x, y) = (c div H, c mod H).
fn column_major(c: usize, _: u32, h: u32) -> (u32, u32) {
    (c as u32 / h, c as u32 % h)
}

fn mutants() -> Vec<(&'static str, &'static str, Port)> {
    let with = |f: fn(&mut Port)| {
        let mut p = AS_KERNEL;
        f(&mut p);
        p
    };
    vec![
        (
            "neighbour_offset_added",
            "U_k = o_c − d_k/R + o_{n_k}: the neighbour's offset added, not subtracted",
            with(|p| p.fan = neighbour_offset_added),
        ),
        (
            "clamped_border",
            "periodic border ignored: neighbours clamped to the map, not wrapped",
            with(|p| p.fan = clamped_border),
        ),
        (
            "corners_swapped",
            "triangle geometry from (P_k, P_{k−1}): (P2 − P1)·P2 and P1·(P1 − P2) swapped",
            with(|p| p.fan = corners_swapped),
        ),
        (
            "stencil_clockwise",
            "the fan walked clockwise: T_k = (c, n_{k+1}, n_k), every triangle folded",
            with(|p| p.fan = stencil_clockwise),
        ),
        (
            "heights_ignored",
            "the 3D edge's z_c − z_n dropped (the flat map's geometry)",
            with(|p| p.fan = heights_ignored),
        ),
        (
            "pin_gradient_dropped",
            "∇F without the pin barrier's gradient",
            with(|p| p.gradient = pin_gradient_dropped),
        ),
        (
            "ascending",
            "the step along +∇F",
            with(|p| p.gradient = ascending),
        ),
        (
            "pin_gradient_halved",
            "∇E_pin = ½ ∇q / (1 − q)² with ∇q = w² R² o (its 2 dropped)",
            with(|p| p.gradient = pin_gradient_halved),
        ),
        (
            "column_major",
            "active index c read column-major: (x, y) = (c div H, c mod H)",
            with(|p| p.texel_of = column_major),
        ),
    ]
}

/// The body with the pin weights read as 0 (pins ignored).
fn pins_ignored(b: &Bindings<F>, c: usize) -> TexelResult<F> {
    let zero = vec![F::lit(0.0); b.pins.len()];
    unwarp_pass_invocation(&Bindings { pins: &zero, ..*b }, c)
}

/// The body with the barrier on the offset in UV units: R_pin = (1, 1).
fn pin_in_uv_units(b: &Bindings<F>, c: usize) -> TexelResult<F> {
    let mut params = b.params;
    params.pin_resolution = V2::splat(F::lit(1.0));
    unwarp_pass_invocation(&Bindings { params, ..*b }, c)
}

/// The body with each offset's components read as (v, u).
fn offsets_swapped(b: &Bindings<F>, c: usize) -> TexelResult<F> {
    let swapped: Vec<V2<F>> = b.offsets.iter().map(|o| V2::new(o.y, o.x)).collect();
    let r = unwarp_pass_invocation(
        &Bindings {
            offsets: &swapped,
            ..*b
        },
        c,
    );
    TexelResult {
        offset: V2::new(r.offset.y, r.offset.x),
        ..r
    }
}

/// Every texel of the grid updated in row-major order, in place, active or not (the phase
/// ignored: an active texel reads neighbours already moved in this pass); the active ones'
/// results reported.
fn every_texel_in_place(k: &KernelVectors) -> Array {
    let x = inputs(k);
    let all = Inputs {
        active: (0..x.z.len()).collect(),
        ..x.clone()
    };
    let moved = all.run(Model::Nearest, unwarp_pass_invocation).to_f64();
    let values = x
        .active
        .iter()
        .flat_map(|&c| [moved[2 * c] as f32, moved[2 * c + 1] as f32])
        .collect();
    Array::f32(&[x.active.len(), 2], values)
}

#[test]
fn every_model_passes_every_mutant_fails_and_no_bound_is_zero() {
    let k = kernel();
    let dir = common::canonical::dir(ALGORITHM);
    let bounds = Array::load(&dir.join(&k.bound.file)).unwrap().to_f64();
    let zero = bounds.iter().filter(|&&b| b == 0.0).count();
    assert_eq!(zero, 0, "{zero} of {} bounds are exactly 0", bounds.len());
    let mut table = MutationTable::default();
    for model in Model::CHECKED {
        let r = judge(&k, &candidate(&dir, &k, model).unwrap());
        table.twin(&model.name(), &r);
    }
    for (name, mistake, port) in mutants() {
        let r = judge(&k, &port_candidate(&k, port, Model::Nearest));
        table.mutant(name, mistake, &r);
    }
    let bodies: [(&str, &str, Body); 3] = [
        ("pins_ignored", "the pin weights read as 0", pins_ignored),
        (
            "pin_in_uv_units",
            "the barrier on the offset in UV units: q = ‖w o‖², R_pin left out",
            pin_in_uv_units,
        ),
        (
            "offsets_swapped",
            "each offset read (and written) as (v, u)",
            offsets_swapped,
        ),
    ];
    for (name, mistake, body) in bodies {
        let r = judge(&k, &inputs(&k).run(Model::Nearest, body));
        table.mutant(name, mistake, &r);
    }
    let r = judge(&k, &every_texel_in_place(&k));
    table.mutant(
        "every_texel_in_place",
        "the phase ignored: every texel updated in place in row-major order",
        &r,
    );
    table.finish();
}

// gridwarp_lookup: the warped texture lookup of a UV atlas with several solved ROIs (seed 000
// §6; the inverse bilinear map of §8; the ROI border blend of §10.2), one invocation per query
// UV: what a renderer runs in its fragment shader. Prepended by the host: dispatch.wgsl.
//
// Twin of src/gridwarp/remap.rs, name for name and in the same order of operations:
// `AtlasRemap::lookup_uv` (here `lookup_uv`, with `contains`, `st`, `uv` of `Roi`),
// `Remap::lookup`, `Remap::locate`, `Remap::blend_weight`, `cell_of`, `quad`, `bilinear`,
// `quadratic`, `roots`, `root_distance`, `choose_root`, `alpha_of`, `newton_polish`,
// `inverse_bilinear`, `inverse_bilinear_with_root`, `in_bbox`, `outside`,
// `locate_in_vertices`. Its f32 CPU twin is src/twin/gridwarp_lookup.rs.
//
// Where the kernel differs from the reference, for the GPU's sake and not in the formula:
// - every ROI's grid lives in four flat tables (`rois`, `roi_grids`, `rest_lines`, `warped`),
//   each ROI's part found by the offsets of its `RoiGrid` (the reference holds a `Grid` and a
//   `VertexGrid` per ROI); an AA ROI's warped part is its lines, an NAA ROI's its vertices;
// - the reference's 2-D cross product `cross` is `cross2` here (WGSL's `cross` is the 3-D one);
// - sgn(b) of `roots` is read from b's sign bit (f64 `signum`: sgn(−0) = −1); a far root the
//   reference leaves out (`None`) is `valid = false`, and the distance of a non-finite root,
//   +∞ in the reference, is f32::MAX (only compared, strictly);
// - `Option` results are structs with a `found` flag.
//
// Per query uv (src/gridwarp/remap.rs, module docs): the first ROI k whose closed rectangle
// [u0, u1] × [v0, v1] contains uv; p = ((u − u0)/(u1 − u0), (v − v0)/(v1 − v0)) clamped to
// [0, 1]²; its warped cell (i, j) and position (α, β) there (AA: the lines' cells,
// α = (p_s − s_i)/(s_{i+1} − s_i); NAA: the inverse bilinear map of the quad containing p);
// the rest point (ŝ_i + α h_i, t̂_j + β k_j); with blending, (1 − w) rest + w p,
// w = 1 − (1 − w_s)(1 − w_t); back to UV, (u0 + s (u1 − u0), v0 + t (v1 − v0)). A uv in no
// ROI is returned unchanged.

const AA: u32 = 0u;
const NAA: u32 = 1u;
// `FAR_ROOT`: a far root is considered only when |q| ≤ 4 |a|.
const FAR_ROOT: f32 = 4.0;
// `BBOX_SLACK` = 2⁻¹².
const BBOX_SLACK: f32 = 0.000244140625;
// +∞ of the reference's `root_distance`.
const NO_DISTANCE: f32 = 3.4028235e38;

struct LookupParams {
    count: u32,        // queries
    rois: u32,         // ROIs
    _pad0: u32,
    _pad1: u32,
}

// A ROI's rectangle in UV (16 bytes; `RoiRect` in gpu/src/gridwarp/lookup.rs).
struct Roi {
    u0: f32,
    u1: f32,
    v0: f32,
    v1: f32,
}

// A ROI's grid (24 bytes; `RoiGrid`): AA or NAA, blending on (1) or off (0), M × N lines (or
// vertices), and where its rest lines (ŝ_0 … ŝ_{M−1}, t̂_0 … t̂_{N−1}) start in `rest_lines`
// and its warped part in `warped` (AA: s_0 … s_{M−1}, t_0 … t_{N−1}; NAA: P_ab = (s, t) at
// 2(a·N + b)).
struct RoiGrid {
    variant: u32,
    blend: u32,
    m: u32,
    n: u32,
    rest: u32,
    warped: u32,
}

@group(0) @binding(0) var<uniform> params: LookupParams;
@group(0) @binding(1) var<storage, read> rois: array<Roi>;
@group(0) @binding(2) var<storage, read> roi_grids: array<RoiGrid>;
@group(0) @binding(3) var<storage, read> rest_lines: array<f32>;
@group(0) @binding(4) var<storage, read> warped: array<f32>;
@group(0) @binding(5) var<storage, read> queries: array<vec2<f32>>;
@group(0) @binding(6) var<storage, read_write> looked_up: array<vec2<f32>>;

fn is_finite(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7f800000u) != 0x7f800000u;
}

fn clamp01(p: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(clamp(p.x, 0.0, 1.0), clamp(p.y, 0.0, 1.0));
}

// `Roi::contains`: the closed rectangle.
fn contains(r: Roi, uv: vec2<f32>) -> bool {
    return uv.x >= r.u0 && uv.x <= r.u1 && uv.y >= r.v0 && uv.y <= r.v1;
}

// `Roi::st`: ROI coordinates of a UV point.
fn st(r: Roi, uv: vec2<f32>) -> vec2<f32> {
    return vec2<f32>((uv.x - r.u0) / (r.u1 - r.u0), (uv.y - r.v0) / (r.v1 - r.v0));
}

// `Roi::uv`: the UV point of ROI coordinates.
fn uv(r: Roi, p: vec2<f32>) -> vec2<f32> {
    return vec2<f32>(r.u0 + p.x * (r.u1 - r.u0), r.v0 + p.y * (r.v1 - r.v0));
}

// `cell_of`: the largest k in 1 … count − 2 with lines[k] ≤ x, else 0 (the lines at
// warped[offset ..]).
fn cell_of(offset: u32, count: u32, x: f32) -> u32 {
    var cell = 0u;
    for (var k = 1u; k + 1u < count; k++) {
        if (warped[offset + k] <= x) {
            cell = k;
        }
    }
    return cell;
}

// `cross`: a × b = a_x b_y − a_y b_x.
fn cross2(a: vec2<f32>, b: vec2<f32>) -> f32 {
    return a.x * b.y - a.y * b.x;
}

// `quad`: the corners [P00, P10, P01, P11] of cell (i, j).
fn vertex(g: RoiGrid, a: u32, b: u32) -> vec2<f32> {
    let o = g.warped + 2u * (a * g.n + b);
    return vec2<f32>(warped[o], warped[o + 1u]);
}

fn quad(g: RoiGrid, i: u32, j: u32) -> array<vec2<f32>, 4> {
    return array<vec2<f32>, 4>(vertex(g, i, j), vertex(g, i + 1u, j), vertex(g, i, j + 1u), vertex(g, i + 1u, j + 1u));
}

// `bilinear`: (1−α)(1−β) P00 + α(1−β) P10 + (1−α)β P01 + αβ P11.
fn bilinear(q: array<vec2<f32>, 4>, alpha: f32, beta: f32) -> vec2<f32> {
    return (1.0 - alpha) * (1.0 - beta) * q[0]
        + alpha * (1.0 - beta) * q[1]
        + (1.0 - alpha) * beta * q[2]
        + alpha * beta * q[3];
}

// `Quadratic`: a β² + b β + c = 0 of the quad re-centred on P00.
struct Quadratic {
    e: vec2<f32>,
    f: vec2<f32>,
    g: vec2<f32>,
    d: vec2<f32>,
    a: f32,
    b: f32,
    c: f32,
}

// `quadratic`: e = P10 − P00, f = P01 − P00, g = (P11 − P10) − f, d = p − P00;
// a = f × g, b = f × e − d × g, c = −(d × e).
fn quadratic(q: array<vec2<f32>, 4>, p: vec2<f32>) -> Quadratic {
    let e = q[1] - q[0];
    let f = q[2] - q[0];
    let g = (q[3] - q[1]) - f;
    let d = p - q[0];
    return Quadratic(e, f, g, d, cross2(f, g), cross2(f, e) - cross2(d, g), -cross2(d, e));
}

// `roots`: q = −½ (b + sgn(b) √max(b² − 4ac, 0)), near = c/q, far = q/a where |q| ≤ 4|a|.
struct Roots {
    near: f32,
    far: f32,
    far_valid: bool,
}

fn roots(k: Quadratic) -> Roots {
    let disc = sqrt(max(k.b * k.b - 4.0 * k.a * k.c, 0.0));
    let sgn = select(1.0, -1.0, (bitcast<u32>(k.b) & 0x80000000u) != 0u);
    let q = -0.5 * (k.b + sgn * disc);
    let near = k.c / q;
    if (abs(q) <= FAR_ROOT * abs(k.a)) {
        return Roots(near, q / k.a, true);
    }
    return Roots(near, 0.0, false);
}

// `root_distance`: how far a root lies outside [0, 1] (NO_DISTANCE if not finite).
fn root_distance(x: f32) -> f32 {
    if (is_finite(x)) {
        return abs(x - clamp(x, 0.0, 1.0));
    }
    return NO_DISTANCE;
}

// `choose_root`: the near root unless the far one is strictly nearer to [0, 1].
fn choose_root(r: Roots) -> f32 {
    if (r.far_valid && root_distance(r.far) < root_distance(r.near)) {
        return r.far;
    }
    return r.near;
}

// `alpha_of`: (d − β f)·(e + β g) / ‖e + β g‖².
fn alpha_of(k: Quadratic, beta: f32) -> f32 {
    let axis = k.e + beta * k.g;
    let rhs = k.d - beta * k.f;
    let n2 = axis.x * axis.x + axis.y * axis.y;
    return (rhs.x * axis.x + rhs.y * axis.y) / n2;
}

// `newton_polish`: one Newton step on W(α, β) = p, J = [e + β g, f + α g].
fn newton_polish(q: array<vec2<f32>, 4>, p: vec2<f32>, k: Quadratic, ab: vec2<f32>) -> vec2<f32> {
    let alpha = ab.x;
    let beta = ab.y;
    let w = bilinear(q, alpha, beta);
    let r = p - w;
    let ja = k.e + beta * k.g;
    let jb = k.f + alpha * k.g;
    let det = cross2(ja, jb);
    if (abs(det) > 0.0 && is_finite(det)) {
        let da = cross2(r, jb) / det;
        let db = cross2(ja, r) / det;
        if (is_finite(da) && is_finite(db)) {
            return vec2<f32>(alpha + da, beta + db);
        }
    }
    return vec2<f32>(alpha, beta);
}

struct Solution {
    found: bool,
    ab: vec2<f32>,
}

// `inverse_bilinear_with_root`: α for the root β, then one Newton step.
fn inverse_bilinear_with_root(q: array<vec2<f32>, 4>, p: vec2<f32>, k: Quadratic, beta: f32) -> Solution {
    let alpha = alpha_of(k, beta);
    if (!is_finite(alpha) || !is_finite(beta)) {
        return Solution(false, vec2<f32>(0.0));
    }
    return Solution(true, newton_polish(q, p, k, vec2<f32>(alpha, beta)));
}

// `inverse_bilinear`: W(α, β) = p for the quad q.
fn inverse_bilinear(q: array<vec2<f32>, 4>, p: vec2<f32>) -> Solution {
    let k = quadratic(q, p);
    return inverse_bilinear_with_root(q, p, k, choose_root(roots(k)));
}

// `in_bbox`: the corners' box, widened by BBOX_SLACK times its half-perimeter, holds p.
fn in_bbox(q: array<vec2<f32>, 4>, p: vec2<f32>) -> bool {
    var lo = q[0];
    var hi = q[0];
    for (var c = 1u; c < 4u; c++) {
        lo = vec2<f32>(min(lo.x, q[c].x), min(lo.y, q[c].y));
        hi = vec2<f32>(max(hi.x, q[c].x), max(hi.y, q[c].y));
    }
    let slack = BBOX_SLACK * ((hi.x - lo.x) + (hi.y - lo.y));
    return !(p.x < lo.x - slack || p.x > hi.x + slack || p.y < lo.y - slack || p.y > hi.y + slack);
}

// `outside`: how far (α, β) lies outside [0, 1]².
fn outside(ab: vec2<f32>) -> f32 {
    return max(max(0.0, abs(ab.x - clamp(ab.x, 0.0, 1.0))), abs(ab.y - clamp(ab.y, 0.0, 1.0)));
}

// `Located`: the warped cell (i, j), (α, β) in it and the rest point.
struct Located {
    found: bool,
    i: u32,
    j: u32,
    alpha: f32,
    beta: f32,
    rest: vec2<f32>,
}

// `locate_in_vertices`: column-major over the cells whose box holds p, the first whose (α, β)
// lies in [0, 1]², else the one nearest to it (the first on ties), clamped.
fn locate_in_vertices(g: RoiGrid, p: vec2<f32>) -> Located {
    var best = Located(false, 0u, 0u, 0.0, 0.0, vec2<f32>(0.0));
    var best_miss = 0.0;
    for (var i = 0u; i + 1u < g.m; i++) {
        for (var j = 0u; j + 1u < g.n; j++) {
            let q = quad(g, i, j);
            if (!in_bbox(q, p)) {
                continue;
            }
            let s = inverse_bilinear(q, p);
            if (!s.found) {
                continue;
            }
            let miss = outside(s.ab);
            if (miss <= 0.0) {
                return Located(true, i, j, s.ab.x, s.ab.y, vec2<f32>(0.0));
            }
            if (!best.found || miss < best_miss) {
                best_miss = miss;
                best = Located(true, i, j, s.ab.x, s.ab.y, vec2<f32>(0.0));
            }
        }
    }
    best.alpha = clamp(best.alpha, 0.0, 1.0);
    best.beta = clamp(best.beta, 0.0, 1.0);
    return best;
}

// `Remap::locate`: p clamped to the unit square, its warped cell and (α, β) (AA: the lines;
// NAA: the quads), and the rest point (ŝ_i + α h_i, t̂_j + β k_j).
fn locate(g: RoiGrid, p_in: vec2<f32>) -> Located {
    let p = clamp01(p_in);
    var at: Located;
    if (g.variant == AA) {
        let i = cell_of(g.warped, g.m, p.x);
        let j = cell_of(g.warped + g.m, g.n, p.y);
        let s0 = warped[g.warped + i];
        let s1 = warped[g.warped + i + 1u];
        let t0 = warped[g.warped + g.m + j];
        let t1 = warped[g.warped + g.m + j + 1u];
        at = Located(true, i, j, (p.x - s0) / (s1 - s0), (p.y - t0) / (t1 - t0), vec2<f32>(0.0));
    } else {
        at = locate_in_vertices(g, p);
        if (!at.found) {
            return at;
        }
    }
    let rs0 = rest_lines[g.rest + at.i];
    let rs1 = rest_lines[g.rest + at.i + 1u];
    let rt0 = rest_lines[g.rest + g.m + at.j];
    let rt1 = rest_lines[g.rest + g.m + at.j + 1u];
    at.rest = vec2<f32>(rs0 + at.alpha * (rs1 - rs0), rt0 + at.beta * (rt1 - rt0));
    return at;
}

// `blend_weight`'s `edge`: 1 − x in the first cell, x in the last, clamped; 0 elsewhere.
fn edge(k: u32, cells: u32, x: f32) -> f32 {
    var w = 0.0;
    if (k == 0u) {
        w = max(w, 1.0 - x);
    }
    if (k + 1u == cells) {
        w = max(w, x);
    }
    return clamp(w, 0.0, 1.0);
}

// `Remap::blend_weight`: w = 1 − (1 − w_s)(1 − w_t); 0 without blending.
fn blend_weight(g: RoiGrid, at: Located) -> f32 {
    if (g.blend == 0u) {
        return 0.0;
    }
    let ws = edge(at.i, g.m - 1u, at.alpha);
    let wt = edge(at.j, g.n - 1u, at.beta);
    return 1.0 - (1.0 - ws) * (1.0 - wt);
}

// `Remap::lookup`: the rest point, blended with p in the boundary cells.
fn lookup(g: RoiGrid, p: vec2<f32>) -> vec2<f32> {
    let at = locate(g, p);
    if (!at.found) {
        return p;
    }
    let w = blend_weight(g, at);
    if (w == 0.0) {
        return at.rest;
    }
    let pc = clamp01(p);
    return vec2<f32>((1.0 - w) * at.rest.x + w * pc.x, (1.0 - w) * at.rest.y + w * pc.y);
}

// `AtlasRemap::lookup_uv`: through the first ROI containing uv, else uv unchanged.
fn lookup_uv(q: vec2<f32>) -> vec2<f32> {
    for (var k = 0u; k < params.rois; k++) {
        let r = rois[k];
        if (contains(r, q)) {
            return uv(r, lookup(roi_grids[k], st(r, q)));
        }
    }
    return q;
}

@compute @workgroup_size(WORKGROUP_SIZE)
fn main(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) workgroups: vec3<u32>) {
    let index = linear_index(gid, workgroups);
    if (index >= params.count) {
        return;
    }
    looked_up[index] = lookup_uv(queries[index]);
}

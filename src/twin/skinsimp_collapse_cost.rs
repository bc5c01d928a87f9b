//! Twin of `gpu/shaders/skinsimp_collapse_cost.wgsl`, function for function: for one
//! candidate (edge (a, b), fixed weights α over the candidate bones) the position step and the
//! collapse cost of seed 003 §5 (`skinsimp::cost::position_given_weights`):
//!
//! - A^j = Σ_k α_k M_k^j ([`blend`]), Q^j = Q_a^j + Q_b^j ([`summed_quadric`]);
//! - Q̃ = Σ_j A^{jT} Q^j A^j ([`position_quadric`]);
//! - v = −B⁻¹ b for B = Q̃\[0:3,0:3\], b = Q̃\[0:3,3\], when cond_F(B) ≤ max_condition
//!   ([`solve_position`]);
//! - v̂ = the least v̂ᵀQ̃v̂ among {v, a, b, (a + b)/2}, ties to the earlier
//!   ([`skinsimp_collapse_cost`]);
//! - E(v̂, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂) ([`energy`]).
//!
//! Matrices are WGSL's `mat4x4<f32>`: four columns, `m[c][r]` the entry of row r, column c.
//! A matrix product's entry and a matrix–vector product's component are 4-term dot products
//! ([`dot`]: the models reorder and fuse them as a GPU may).

use super::coverage::{branches, hit, taken, Branch};
use super::real::{abs, cross, dot, is_finite, max, sqrt, Real, V3};

/// `skinsimp_collapse_cost`'s branches ([`super::coverage`]).
pub const BRANCHES: &[Branch] = branches![
    "skinsimp_collapse_cost.blend.used" => "a bone with α_k ≠ 0: α_k M_k^j added to A^j",
    "skinsimp_collapse_cost.blend.skipped" => "a bone slot with α_k = 0: skipped",
    "skinsimp_collapse_cost.solve.singular" => "det B = 0: no solution",
    "skinsimp_collapse_cost.solve.ill_conditioned" => "cond_F(B) > max_condition (or NaN): no solution",
    "skinsimp_collapse_cost.solve.not_finite" => "v = −B⁻¹ b not finite: no solution",
    "skinsimp_collapse_cost.solve.found" => "v = −B⁻¹ b kept as the first choice",
    "skinsimp_collapse_cost.choice.solution" => "the solution kept: no fallback strictly below it",
    "skinsimp_collapse_cost.choice.a" => "fallback a kept",
    "skinsimp_collapse_cost.choice.b" => "fallback b kept",
    "skinsimp_collapse_cost.choice.midpoint" => "fallback (a + b)·0.5 kept",
    "skinsimp_collapse_cost.choice.first_without_solution" => "no solution: fallback a taken as the first point, whatever its value",
];

/// `CHOICE_SOLUTION`: the kept point is the solve's; 1, 2, 3 name the fallbacks a, b and the
/// midpoint.
pub const CHOICE_SOLUTION: u32 = 0;

/// `mat4x4<f32>`: four columns of four rows.
pub type M4<R> = [[R; 4]; 4];

/// The buffers the kernel reads (its bindings 0–3), as f32.
#[derive(Clone, Copy, Debug)]
pub struct Buffers<'a> {
    /// `rest`: 3 per vertex.
    pub rest: &'a [f32],
    /// `vertex_quadrics`: 10 per (vertex, pose), index `10 (i · P + j)`, upper triangle row by
    /// row.
    pub vertex_quadrics: &'a [f32],
    /// `joints`: the 3 × 4 top of each joint matrix, row by row, 12 per (pose, joint).
    pub joints: &'a [f32],
    pub pose_count: u32,
    pub joint_count: u32,
    pub max_condition: f32,
}

/// `EdgeItem`: one candidate, its K ≤ 8 bones and their weights α.
#[derive(Clone, Debug, PartialEq)]
pub struct EdgeItem {
    pub a: u32,
    pub b: u32,
    pub joints: Vec<u32>,
    pub alpha: Vec<f32>,
}

/// `EdgeCost`: what the kernel writes for one candidate.
#[derive(Clone, Copy, Debug)]
pub struct EdgeCost<R> {
    /// Q̃, upper triangle row by row.
    pub quadric: [R; 10],
    /// ‖B‖_F ‖B⁻¹‖_F (0 when det B = 0).
    pub condition: R,
    /// v̂ᵀQ̃v̂ at the kept point.
    pub value: R,
    pub position: V3<R>,
    /// E(v̂, α).
    pub cost: R,
    pub choice: u32,
}

fn read<R: Real>(x: f32) -> R {
    R::lit(x as f64)
}

/// `rest_at`: vertex v's rest position.
pub fn rest_at<R: Real>(buffers: &Buffers, v: u32) -> V3<R> {
    let o = 3 * v as usize;
    let r = buffers.rest;
    V3::new(read(r[o]), read(r[o + 1]), read(r[o + 2]))
}

/// The zero matrix.
pub fn zero_matrix<R: Real>() -> M4<R> {
    [[R::lit(0.0); 4]; 4]
}

/// Row r of `m`.
fn row<R: Real>(m: &M4<R>, r: usize) -> [R; 4] {
    [m[0][r], m[1][r], m[2][r], m[3][r]]
}

/// `m * v`: component r is row r of m dotted with v.
pub fn times_vector<R: Real>(m: &M4<R>, v: [R; 4]) -> [R; 4] {
    std::array::from_fn(|r| dot(row(m, r), v))
}

/// `a * b`: column c is a times column c of b.
pub fn times_matrix<R: Real>(a: &M4<R>, b: &M4<R>) -> M4<R> {
    std::array::from_fn(|c| times_vector(a, b[c]))
}

/// `transpose(m)`.
pub fn transpose<R: Real>(m: &M4<R>) -> M4<R> {
    std::array::from_fn(|c| row(m, c))
}

/// `a + b`, entry by entry.
pub fn plus<R: Real>(a: &M4<R>, b: &M4<R>) -> M4<R> {
    std::array::from_fn(|c| std::array::from_fn(|r| a[c][r] + b[c][r]))
}

/// `m * w`, entry by entry.
pub fn scaled<R: Real>(m: &M4<R>, w: R) -> M4<R> {
    std::array::from_fn(|c| std::array::from_fn(|r| m[c][r] * w))
}

/// `quadric_matrix`: the symmetric 4 × 4 of an upper triangle (row by row).
pub fn quadric_matrix<R: Real>(q: &[R; 10]) -> M4<R> {
    [
        [q[0], q[1], q[2], q[3]],
        [q[1], q[4], q[5], q[6]],
        [q[2], q[5], q[7], q[8]],
        [q[3], q[6], q[8], q[9]],
    ]
}

/// The upper triangle of `m`, row by row (the kernel's `out.quadric`).
pub fn upper_triangle<R: Real>(m: &M4<R>) -> [R; 10] {
    [
        m[0][0], m[1][0], m[2][0], m[3][0], m[1][1], m[2][1], m[3][1], m[2][2], m[3][2], m[3][3],
    ]
}

/// Vertex v's quadric in `pose`, as read from the buffer.
pub fn vertex_quadric<R: Real>(buffers: &Buffers, v: u32, pose: u32) -> [R; 10] {
    let o = 10 * (v * buffers.pose_count + pose) as usize;
    std::array::from_fn(|k| read(buffers.vertex_quadrics[o + k]))
}

/// `summed_quadric`: Q^j = Q_a^j + Q_b^j.
pub fn summed_quadric<R: Real>(buffers: &Buffers, item: &EdgeItem, pose: u32) -> M4<R> {
    let qa: [R; 10] = vertex_quadric(buffers, item.a, pose);
    let qb: [R; 10] = vertex_quadric(buffers, item.b, pose);
    quadric_matrix(&std::array::from_fn(|k| qa[k] + qb[k]))
}

/// `joint_matrix`: the affine M of `joint` in `pose` (the buffer holds its top 3 rows, row by
/// row; the last row is (0, 0, 0, 1)).
pub fn joint_matrix<R: Real>(buffers: &Buffers, pose: u32, joint: u32) -> M4<R> {
    let o = 12 * (pose * buffers.joint_count + joint) as usize;
    let m = |k: usize| read::<R>(buffers.joints[o + k]);
    let (zero, one) = (R::lit(0.0), R::lit(1.0));
    [
        [m(0), m(4), m(8), zero],
        [m(1), m(5), m(9), zero],
        [m(2), m(6), m(10), zero],
        [m(3), m(7), m(11), one],
    ]
}

/// `blend` (`Candidates::blend`): A^j = Σ_k α_k M_k^j, zero weights skipped.
pub fn blend<R: Real>(buffers: &Buffers, item: &EdgeItem, pose: u32) -> M4<R> {
    let mut a = zero_matrix();
    for (&joint, &w) in item.joints.iter().zip(&item.alpha) {
        if taken(
            w != 0.0,
            "skinsimp_collapse_cost.blend.used",
            "skinsimp_collapse_cost.blend.skipped",
        ) {
            a = plus(&a, &scaled(&joint_matrix(buffers, pose, joint), read(w)));
        }
    }
    a
}

/// `position_quadric`: Q̃ = Σ_j A^{jT} Q^j A^j, poses in order.
pub fn position_quadric<R: Real>(buffers: &Buffers, item: &EdgeItem) -> M4<R> {
    let mut total = zero_matrix();
    for j in 0..buffers.pose_count {
        let a = blend(buffers, item, j);
        let aq = times_matrix(&transpose(&a), &summed_quadric(buffers, item, j));
        total = plus(&total, &times_matrix(&aq, &a));
    }
    total
}

/// The homogeneous point (v, 1).
fn homogeneous<R: Real>(v: V3<R>) -> [R; 4] {
    [v.x, v.y, v.z, R::lit(1.0)]
}

/// `energy`: E(v̂, α) = Σ_j (A^j v̂)ᵀ Q^j (A^j v̂), poses in order.
pub fn energy<R: Real>(buffers: &Buffers, item: &EdgeItem, v: V3<R>) -> R {
    let h = homogeneous(v);
    let mut e = R::lit(0.0);
    for j in 0..buffers.pose_count {
        let p = times_vector(&blend(buffers, item, j), h);
        e = e + dot(p, times_vector(&summed_quadric(buffers, item, j), p));
    }
    e
}

/// `quadric_value`: v̂ᵀ Q v̂.
pub fn quadric_value<R: Real>(q: &M4<R>, v: V3<R>) -> R {
    let h = homogeneous(v);
    dot(h, times_vector(q, h))
}

/// `max_abs3`: the largest |component|.
pub fn max_abs3<R: Real>(x: V3<R>) -> R {
    max(max(abs(x.x), abs(x.y)), abs(x.z))
}

/// The binary exponent e of `frexp(x)` (x = m 2^e, ½ ≤ |m| < 1; 0 for x = 0).
pub fn frexp_exponent(x: f64) -> i32 {
    if x == 0.0 || !x.is_finite() {
        return 0;
    }
    // Every f32 (subnormals included) is a normal f64.
    ((x.to_bits() >> 52) & 0x7ff) as i32 - 1022
}

/// `ldexp(x, e)` = x 2^e, exact in WGSL: two exact products by 2^⌊e/2⌋ and 2^(e − ⌊e/2⌋)
/// (each factor an f32; 2^e alone may not be one).
pub fn ldexp<R: Real>(x: V3<R>, e: i32) -> V3<R> {
    let half = e.div_euclid(2);
    x * R::lit(2f64.powi(half)) * R::lit(2f64.powi(e - half))
}

/// `condition <= max_condition` (false for a NaN: the kernel's `!(cond <= max)` refuses it).
pub fn condition_within(condition: f64, max_condition: f32) -> bool {
    matches!(
        condition.partial_cmp(&(max_condition as f64)),
        Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
    )
}

/// `Solution`.
#[derive(Clone, Copy, Debug)]
pub struct Solution<R> {
    pub found: bool,
    pub v: V3<R>,
    pub condition: R,
}

/// Column c of the upper-left 3 × 3 block.
fn column3<R: Real>(q: &M4<R>, c: usize) -> V3<R> {
    V3::new(q[c][0], q[c][1], q[c][2])
}

/// `solve_position`: v = −B⁻¹ b with the adjugate inverse (rows of B⁻¹ = (c1 × c2, c2 × c0,
/// c0 × c1) / det for the columns c of B), B and b first scaled by 2^−e, 2^e the binary exponent
/// of B's largest entry (exact; cond_F and v are unchanged by a common scale); none when
/// det = 0, when cond_F = ‖B‖_F ‖B⁻¹‖_F exceeds `max_condition` (or is not a number), or when v
/// is not finite.
pub fn solve_position<R: Real>(q: &M4<R>, max_condition: f32) -> Solution<R> {
    let largest = max(
        max(max_abs3(column3(q, 0)), max_abs3(column3(q, 1))),
        max_abs3(column3(q, 2)),
    );
    let shift = -frexp_exponent(largest.value());
    let c0 = ldexp(column3(q, 0), shift);
    let c1 = ldexp(column3(q, 1), shift);
    let c2 = ldexp(column3(q, 2), shift);
    let b = ldexp(V3::new(q[3][0], q[3][1], q[3][2]), shift);
    let r0 = cross(c1, c2);
    let r1 = cross(c2, c0);
    let r2 = cross(c0, c1);
    let det = dot(c0.to_array(), r0.to_array());
    let mut out = Solution {
        found: false,
        v: V3::splat(R::lit(0.0)),
        condition: R::lit(0.0),
    };
    if det.value() == 0.0 {
        hit("skinsimp_collapse_cost.solve.singular");
        return out;
    }
    let squares = |a: V3<R>, b: V3<R>, c: V3<R>| {
        dot(a.to_array(), a.to_array())
            + dot(b.to_array(), b.to_array())
            + dot(c.to_array(), c.to_array())
    };
    let norm_b = sqrt(squares(c0, c1, c2));
    let norm_inv = sqrt(squares(r0, r1, r2)) / abs(det);
    out.condition = norm_b * norm_inv;
    if !condition_within(out.condition.value(), max_condition) {
        hit("skinsimp_collapse_cost.solve.ill_conditioned");
        return out;
    }
    let v = -V3::new(
        dot(r0.to_array(), b.to_array()),
        dot(r1.to_array(), b.to_array()),
        dot(r2.to_array(), b.to_array()),
    ) / det;
    out.found = taken(
        is_finite(v.x) && is_finite(v.y) && is_finite(v.z),
        "skinsimp_collapse_cost.solve.found",
        "skinsimp_collapse_cost.solve.not_finite",
    );
    out.v = v;
    out
}

/// `skinsimp_collapse_cost` for one candidate: Q̃, the position step with the fallbacks
/// (a, b, midpoint; the least v̂ᵀQ̃v̂, ties to the earlier) and E(v̂, α).
pub fn skinsimp_collapse_cost<R: Real>(buffers: &Buffers, item: &EdgeItem) -> EdgeCost<R> {
    let q = position_quadric(buffers, item);
    let solution = solve_position(&q, buffers.max_condition);
    let a = rest_at(buffers, item.a);
    let b = rest_at(buffers, item.b);
    let fallbacks = [a, b, (a + b) * R::lit(0.5)];
    let mut found = solution.found;
    let mut best = solution.v;
    let mut best_value = R::lit(0.0);
    let mut choice = CHOICE_SOLUTION;
    if found {
        best_value = quadric_value(&q, best);
    }
    for (k, &point) in fallbacks.iter().enumerate() {
        let e = quadric_value(&q, point);
        if !found || e.decides_lt(best_value) {
            if !found {
                hit("skinsimp_collapse_cost.choice.first_without_solution");
            }
            found = true;
            best = point;
            best_value = e;
            choice = k as u32 + 1;
        }
    }
    hit(match choice {
        CHOICE_SOLUTION => "skinsimp_collapse_cost.choice.solution",
        1 => "skinsimp_collapse_cost.choice.a",
        2 => "skinsimp_collapse_cost.choice.b",
        _ => "skinsimp_collapse_cost.choice.midpoint",
    });
    EdgeCost {
        quadric: upper_triangle(&q),
        condition: solution.condition,
        value: best_value,
        position: best,
        cost: energy(buffers, item, best),
        choice,
    }
}

//! Twin of `gpu/shaders/maps_flatten.wgsl`, function for function: the conformal map z^a of one
//! ordered 1-ring (seed 002 "Constructing the Mesh Hierarchies (4/5)"; notes maps.md
//! "Flattening a 1-ring"; f64 reference [`crate::maps::flatten`]):
//!
//! θ_k = Σ_{m<k} ∠(p_{j_m}, p_i, p_{j_{m+1}}) (θ_0 = 0), r_k = |p_{j_k} − p_i|,
//! μ_k = r_k^a e^{i(a θ_k + offset)}, with a = 2π/θ_K (disk), π/θ_{K−1} (half disk), or per side
//! π/θ_side (feature line), and the guards of `check_sectors` (a·φ < π) and of sanity (every
//! radius positive and finite, θ strictly increasing).
//!
//! The ring (positions, kind, s, t) is [`Ring`] of [`super::maps_priority`] (`maps_rings.wgsl`,
//! shared by both kernels); θ_k is written to the slots by [`cumulative_angles`] and read back,
//! as the kernel does.

use super::coverage::{branches, hit, taken, Branch};
use super::maps_priority::{ring_point, sector_count, Ring, KIND_DISK, KIND_HALF_DISK};
use super::real::{abs, cos, cross, dot, length, pow, sin, Real, V2};

/// `maps_flatten`'s branches ([`super::coverage`]).
pub const BRANCHES: &[Branch] = branches![
    "maps_rings.open" => "a half disk: K − 1 sectors",
    "maps_rings.closed" => "a disk or a feature line: K sectors",
    "maps_flatten.atan.direct" => "atan x for x ≤ tan(π/8): the polynomial in x",
    "maps_flatten.atan.reduced" => "atan x for x > tan(π/8): π/4 + atan((x − 1)/(x + 1))",
    "maps_flatten.angle.zero" => "atan2(0, 0) = 0 (u × v = 0 and u · v = 0)",
    "maps_flatten.angle.below_diagonal" => "y ≤ |x|: atan(y/|x|)",
    "maps_flatten.angle.above_diagonal" => "y > |x|: π/2 − atan(|x|/y)",
    "maps_flatten.angle.obtuse" => "x < 0 (u · v < 0, an obtuse sector): π − t",
    "maps_flatten.angle.near_zero" => "a sector angle φ < 0.05 rad (a sliver: acos(u·v/|u||v|) loses its digits here)",
    "maps_flatten.angle.near_pi" => "a sector angle φ > π − 0.05 (nearly straight: acos loses its digits here)",
    "maps_flatten.theta.closing" => "θ_K read as θ_total (the closing sector of a closed ring)",
    "maps_flatten.sane.radius" => "a radius r_k = 0 or not finite: degenerate",
    "maps_flatten.sane.angle" => "θ not strictly increasing (a sector angle 0) or not finite: degenerate",
    "maps_flatten.kind.disk" => "a disk: a = 2π/θ_K",
    "maps_flatten.kind.half_disk" => "a half disk: a = π/θ_{K−1}",
    "maps_flatten.kind.feature_line" => "a feature line: a₁ = π/(θ_t − θ_s), a₂ = π/(θ_K − (θ_t − θ_s))",
    "maps_flatten.sectors.single" => "a side of a single sector: a flipped fan",
    "maps_flatten.sectors.too_wide" => "a scaled sector a·φ ≥ π: a flipped fan",
    "maps_flatten.sectors.ok" => "every scaled sector a·φ < π",
    "maps_flatten.feature.upper" => "a ring vertex on the upper side s < m < t: angle a₁(θ_m − θ_s)",
    "maps_flatten.feature.lower_after_t" => "a ring vertex on the lower side after t: angle π + a₂(θ_m − θ_t)",
    "maps_flatten.feature.lower_before_s" => "a ring vertex on the lower side before s (past j_0): angle π + a₂(θ_m + θ_K − θ_t)",
    "maps_flatten.wrap.kept" => "an angle ≤ π given to cos and sin as it is",
    "maps_flatten.wrap.shifted" => "an angle > π moved by −2π into [−π, π]",
    "maps_flatten.mu.not_finite" => "a μ not finite: degenerate",
];

/// `PI` as the kernel spells it (its digits, not `std::f64::consts::PI`: the twin rounds the
/// kernel's literal).
#[allow(clippy::approx_constant)]
pub const PI: f64 = 3.14159265358979;
/// `STATUS_OK`.
pub const STATUS_OK: u32 = 0;
/// `STATUS_DEGENERATE` (`FlattenReject::Degenerate`).
pub const STATUS_DEGENERATE: u32 = 1;
/// `STATUS_FLIPPED_FAN` (`FlattenReject::FlippedFan`).
pub const STATUS_FLIPPED_FAN: u32 = 2;

/// `FlatRing`: a (or a₁ of the upper side), a₂ (of the lower side; a otherwise), the last θ
/// (θ_K closed, θ_{K−1} half disk) and the status.
#[derive(Clone, Copy, Debug)]
pub struct FlatRing<R> {
    pub a: R,
    pub a2: R,
    pub theta_total: R,
    pub status: u32,
}

/// `FlatPoint`: μ(p_{j_k}), θ_k and r_k of one ring slot.
#[derive(Clone, Copy, Debug)]
pub struct FlatPoint<R> {
    pub mu: V2<R>,
    pub theta: R,
    pub radius: R,
}

/// `theta_at`: θ_m from slot m, or `total` for m = K (the closing θ_K of a closed ring).
pub fn theta_at<R: Real>(h: &Ring<R>, points: &[FlatPoint<R>], m: usize, total: R) -> R {
    if m >= h.points.len() {
        hit("maps_flatten.theta.closing");
        return total;
    }
    points[m].theta
}

/// `finite`: |x| < f32::MAX (NaN and ±∞ fail).
pub fn finite<R: Real>(x: R) -> bool {
    abs(x).value() < 3.4028234e38
}

/// `atan_unit`: atan x for 0 ≤ x ≤ 1, Cephes' atanf (reduction at tan(π/8) by (x − 1)/(x + 1),
/// then t + t z (c₃ + z (c₂ + z (c₁ + z c₀))) with z = t²).
#[allow(clippy::approx_constant)] // the kernel's literals π/4 and tan(π/8), rounded as it has them
pub fn atan_unit<R: Real>(x: R) -> R {
    let mut base = R::lit(0.0);
    let mut t = x;
    if taken(
        x.value() > f64::from(0.41421356f32),
        "maps_flatten.atan.reduced",
        "maps_flatten.atan.direct",
    ) {
        base = R::lit(0.78539816);
        t = (x - R::lit(1.0)) / (x + R::lit(1.0));
    }
    let z = t * t;
    base + ((((R::lit(8.05374449538e-2) * z - R::lit(1.38776856032e-1)) * z
        + R::lit(1.99777106478e-1))
        * z
        - R::lit(3.33329491539e-1))
        * z
        * t
        + t)
}

/// `angle_atan2`: atan2(y, x) for y ≥ 0 from [`atan_unit`] of min/max (π/2 − atan of the
/// inverse above the diagonal, π − t for x < 0); 0 for y = x = 0.
#[allow(clippy::approx_constant)] // the kernel's literal π/2
pub fn angle_atan2<R: Real>(y: R, x: R) -> R {
    let ax = abs(x);
    if y.value() == 0.0 && ax.value() == 0.0 {
        hit("maps_flatten.angle.zero");
        return R::lit(0.0);
    }
    let t = if taken(
        y.value() <= ax.value(),
        "maps_flatten.angle.below_diagonal",
        "maps_flatten.angle.above_diagonal",
    ) {
        atan_unit(y / ax)
    } else {
        R::lit(1.57079633) - atan_unit(ax / y)
    };
    if x.value() < 0.0 {
        hit("maps_flatten.angle.obtuse");
        return R::lit(PI) - t;
    }
    t
}

/// `cumulative_angles`: θ_{m+1} = θ_m + atan2(|a × b|, a · b) with a = p_{j_m} − p_i,
/// b = p_{j_{m+1}} − p_i over the ring's sectors, written to slots 1 … K − 1 (slot 0: 0); the
/// radii r_k = |p_{j_k} − p_i| to every slot. Returns the last θ (θ_K closed, θ_{K−1} open).
pub fn cumulative_angles<R: Real>(h: &Ring<R>, points: &mut [FlatPoint<R>]) -> R {
    let p = h.centre;
    let mut theta = R::lit(0.0);
    points[0].theta = R::lit(0.0);
    for m in 0..sector_count(h) {
        let a = ring_point(h, m) - p;
        let b = ring_point(h, m + 1) - p;
        let phi = angle_atan2(
            length(cross(a, b).to_array()),
            dot(a.to_array(), b.to_array()),
        );
        if phi.value() < 0.05 {
            hit("maps_flatten.angle.near_zero");
        } else if phi.value() > PI - 0.05 {
            hit("maps_flatten.angle.near_pi");
        }
        theta = theta + phi;
        if m + 1 < h.points.len() {
            points[m + 1].theta = theta;
        }
    }
    for (m, point) in points.iter_mut().enumerate() {
        point.radius = length((ring_point(h, m) - p).to_array());
    }
    theta
}

/// `wrap_angle`: an angle of [0, 3π) moved into [−π, π] (x − 2π above π), where WGSL's `cos`
/// and `sin` have their 2⁻¹¹ absolute accuracy (the table promises nothing outside).
pub fn wrap_angle<R: Real>(angle: R) -> R {
    if taken(
        angle.value() > f64::from(PI as f32),
        "maps_flatten.wrap.shifted",
        "maps_flatten.wrap.kept",
    ) {
        return angle - R::lit(2.0) * R::lit(PI);
    }
    angle
}

/// `polar`: r^a e^{i angle} = (r^a cos angle, r^a sin angle), r^a = `pow(r, a)`.
pub fn polar<R: Real>(r: R, a: R, angle: R) -> V2<R> {
    let rho = pow(r, a);
    let w = wrap_angle(angle);
    V2::new(rho * cos(w), rho * sin(w))
}

/// `check_sectors`: false (a flipped fan) when the side is a single sector (a·φ = π exactly),
/// or when a scaled sector angle a·(θ_{m+1} − θ_m) ≥ π over the sector ranges [first0, end0)
/// and [first1, end1) of the side.
#[allow(clippy::too_many_arguments)] // the kernel's signature
pub fn check_sectors<R: Real>(
    h: &Ring<R>,
    points: &[FlatPoint<R>],
    first0: usize,
    end0: usize,
    first1: usize,
    end1: usize,
    a: R,
    total: R,
) -> bool {
    if (end0 - first0) + (end1 - first1) == 1 {
        hit("maps_flatten.sectors.single");
        return false;
    }
    for m in (first0..end0).chain(first1..end1) {
        let scaled = a * (theta_at(h, points, m + 1, total) - theta_at(h, points, m, total));
        if !scaled.decides_lt(R::lit(PI)) {
            hit("maps_flatten.sectors.too_wide");
            return false;
        }
    }
    hit("maps_flatten.sectors.ok");
    true
}

/// `flatten_ring`: the flattened ring, μ written to its slots (returned with θ_k and r_k), and
/// (a, a₂, θ_total, status) (seed 4/5; notes "Flattening a 1-ring"):
/// - Degenerate when a radius is 0 or not finite, or θ does not strictly increase (μ = 0, a = 0);
/// - Disk: a = 2π/θ_K, μ_k = polar(r_k, a, a θ_k), μ_0 = (r_0^a, 0);
/// - HalfDisk: a = π/θ_{K−1}, μ_0 = (r_0^a, 0), μ_{K−1} = (−r_{K−1}^a, 0);
/// - FeatureLine (s < t): a₁ = π/(θ_t − θ_s) on the upper side s < m < t at angle a₁(θ_m − θ_s),
///   a₂ = π/(θ_K − (θ_t − θ_s)) on the lower side at π + a₂(θ_m − θ_t) (+ θ_K for m < s),
///   μ_s = (r_s^{(a₁+a₂)/2}, 0), μ_t = (−r_t^{(a₁+a₂)/2}, 0);
/// - FlippedFan when [`check_sectors`] fails (μ still written); Degenerate when a μ is not
///   finite.
pub fn flatten_ring<R: Real>(h: &Ring<R>) -> (FlatRing<R>, Vec<FlatPoint<R>>) {
    let zero = R::lit(0.0);
    let k = h.points.len();
    let mut points = vec![
        FlatPoint {
            mu: V2::splat(zero),
            theta: zero,
            radius: zero,
        };
        k
    ];
    let total = cumulative_angles(h, &mut points);
    let mut sane = true;
    for point in points.iter_mut() {
        let radius = point.radius;
        if !(radius.value() > 0.0 && finite(radius)) {
            hit("maps_flatten.sane.radius");
            sane = false;
        }
        point.mu = V2::splat(zero);
    }
    for m in 0..sector_count(h) {
        let next = theta_at(h, &points, m + 1, total);
        if !(next.value() > theta_at(h, &points, m, total).value() && finite(next)) {
            hit("maps_flatten.sane.angle");
            sane = false;
        }
    }
    let mut out = FlatRing {
        a: zero,
        a2: zero,
        theta_total: total,
        status: STATUS_OK,
    };
    if !sane {
        out.status = STATUS_DEGENERATE;
        return (out, points);
    }
    let pi = R::lit(PI);
    if h.kind == KIND_DISK {
        hit("maps_flatten.kind.disk");
        let a = R::lit(2.0) * pi / total;
        out.a = a;
        out.a2 = a;
        if !check_sectors(h, &points, 0, k, 0, 0, a, total) {
            out.status = STATUS_FLIPPED_FAN;
        }
        for point in points.iter_mut() {
            point.mu = polar(point.radius, a, a * point.theta);
        }
        points[0].mu = V2::new(pow(points[0].radius, a), zero);
    } else if h.kind == KIND_HALF_DISK {
        hit("maps_flatten.kind.half_disk");
        let a = pi / total;
        out.a = a;
        out.a2 = a;
        if !check_sectors(h, &points, 0, k - 1, 0, 0, a, total) {
            out.status = STATUS_FLIPPED_FAN;
        }
        for point in &mut points[1..k - 1] {
            point.mu = polar(point.radius, a, a * point.theta);
        }
        points[0].mu = V2::new(pow(points[0].radius, a), zero);
        points[k - 1].mu = V2::new(-pow(points[k - 1].radius, a), zero);
    } else {
        hit("maps_flatten.kind.feature_line");
        let (s, t) = (h.s, h.t);
        let theta_s = points[s].theta;
        let theta_t = points[t].theta;
        let upper = theta_t - theta_s;
        let lower = total - upper;
        let a1 = pi / upper;
        let a2 = pi / lower;
        out.a = a1;
        out.a2 = a2;
        if !check_sectors(h, &points, s, t, 0, 0, a1, total)
            || !check_sectors(h, &points, t, k, 0, s, a2, total)
        {
            out.status = STATUS_FLIPPED_FAN;
        }
        for (m, point) in points.iter_mut().enumerate() {
            let theta = point.theta;
            if m > s && m < t {
                hit("maps_flatten.feature.upper");
                point.mu = polar(point.radius, a1, a1 * (theta - theta_s));
            } else if m != s && m != t {
                let from_t = if taken(
                    m > t,
                    "maps_flatten.feature.lower_after_t",
                    "maps_flatten.feature.lower_before_s",
                ) {
                    theta - theta_t
                } else {
                    theta + total - theta_t
                };
                point.mu = polar(point.radius, a2, pi + a2 * from_t);
            }
        }
        let a_mid = R::lit(0.5) * (a1 + a2);
        points[s].mu = V2::new(pow(points[s].radius, a_mid), zero);
        points[t].mu = V2::new(-pow(points[t].radius, a_mid), zero);
    }
    if out.status == STATUS_OK && points.iter().any(|p| !finite(p.mu.x) || !finite(p.mu.y)) {
        hit("maps_flatten.mu.not_finite");
        out.status = STATUS_DEGENERATE;
    }
    (out, points)
}

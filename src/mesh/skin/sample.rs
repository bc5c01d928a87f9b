//! The value of an animation channel at a time (glTF 2.0 §3.11 and Appendix C).
//!
//! For τ between keys `t_k ≤ τ < t_{k+1}`, with `Δt = t_{k+1} − t_k` and `s = (τ − t_k) / Δt`:
//! - STEP: `v_k`;
//! - LINEAR: `(1 − s) v_k + s v_{k+1}` for translations and scales, spherical linear
//!   interpolation for rotations;
//! - CUBICSPLINE: the Hermite spline of [`hermite`], normalised for rotations.
//!
//! Before the first key the first value holds, after the last key the last one.

use nalgebra::Vector4;

use super::{Channel, Interpolation, Property};

impl Channel {
    /// A channel from a glTF sampler: key `times` and the sampler's `outputs` in glTF layout,
    /// one value per key, or for CUBICSPLINE three per key (in-tangent `a_k`, value `v_k`,
    /// out-tangent `b_k`). Translations and scales are (x, y, z, 0), rotations (x, y, z, w).
    ///
    /// Checks: at least one key, finite non-decreasing times, the right number of outputs,
    /// finite outputs, non-zero rotation keys (normalised here; tangents are kept as given).
    /// `Err` gives the reason.
    pub fn new(
        node: usize,
        property: Property,
        interpolation: Interpolation,
        times: Vec<f64>,
        outputs: Vec<Vector4<f64>>,
    ) -> Result<Channel, String> {
        check_times(&times)?;
        let per_key = if interpolation == Interpolation::CubicSpline {
            3
        } else {
            1
        };
        if outputs.len() != per_key * times.len() {
            return Err(format!(
                "{} key time(s) need {} output value(s) for {interpolation:?}, the sampler has {}",
                times.len(),
                per_key * times.len(),
                outputs.len()
            ));
        }
        if let Some(k) = outputs
            .iter()
            .position(|v| !v.iter().all(|x| x.is_finite()))
        {
            return Err(format!(
                "output value {k} is not finite ({:?})",
                outputs[k].as_slice()
            ));
        }
        let (in_tangents, mut values, out_tangents) = split_outputs(outputs, per_key);
        if property == Property::Rotation {
            normalise_quaternions(&mut values)?;
        }
        Ok(Channel {
            node,
            property,
            interpolation,
            times,
            values,
            in_tangents,
            out_tangents,
        })
    }

    /// The channel's value at time `time` (seconds), clamped to the key range (module docs).
    /// Rotations come out as unit quaternions (x, y, z, w).
    pub fn sample(&self, time: f64) -> Vector4<f64> {
        let (k, s, dt) = match locate(&self.times, time) {
            KeyPosition::At(k) => return self.values[k],
            KeyPosition::Between { k, s, dt } => (k, s, dt),
        };
        let (v0, v1) = (self.values[k], self.values[k + 1]);
        let rotation = self.property == Property::Rotation;
        match self.interpolation {
            Interpolation::Step => v0,
            Interpolation::Linear if rotation => slerp(v0, v1, s),
            Interpolation::Linear => v0.lerp(&v1, s),
            Interpolation::CubicSpline => {
                let p = hermite(v0, self.out_tangents[k], v1, self.in_tangents[k + 1], s, dt);
                if rotation {
                    p.normalize()
                } else {
                    p
                }
            }
        }
    }
}

/// Where a time falls among the keys.
enum KeyPosition {
    /// At or outside the ends: the value of key `k` holds.
    At(usize),
    /// `t_k ≤ τ < t_{k+1}`, `s = (τ − t_k) / Δt`, `Δt = t_{k+1} − t_k > 0`.
    Between { k: usize, s: f64, dt: f64 },
}

/// Locate `time` among the sorted key `times` by binary search. A NaN time gives the first key.
fn locate(times: &[f64], time: f64) -> KeyPosition {
    let last = times.len() - 1;
    if time.is_nan() || time <= times[0] {
        return KeyPosition::At(0);
    }
    if time >= times[last] {
        return KeyPosition::At(last);
    }
    // The first key after `time`; it exists and is not key 0, since t_0 < τ < t_last.
    let next = times.partition_point(|&t| t <= time);
    let k = next - 1;
    let dt = times[next] - times[k];
    KeyPosition::Between {
        k,
        s: (time - times[k]) / dt,
        dt,
    }
}

/// Spherical linear interpolation from unit quaternion `a` (s = 0) to `b` (s = 1) along the
/// shorter arc: `b' = ±b` with `a · b' ≥ 0`, θ the angle between `a` and `b'`, and
/// `q(s) = (sin((1 − s) θ) a + sin(s θ) b') / sin θ`.
///
/// θ is computed as `2 atan2(|a − b'|, |a + b'|)`, accurate even for nearly equal quaternions
/// (where `acos(a · b')` loses half the digits). Below θ = 1e-9 the normalised linear
/// interpolation is used; the two differ by O(θ²).
pub fn slerp(a: Vector4<f64>, b: Vector4<f64>, s: f64) -> Vector4<f64> {
    let b = if a.dot(&b) < 0.0 { -b } else { b };
    let theta = 2.0 * (a - b).norm().atan2((a + b).norm());
    if theta < 1e-9 {
        return a.lerp(&b, s).normalize();
    }
    let q = (a * ((1.0 - s) * theta).sin() + b * (s * theta).sin()) / theta.sin();
    q.normalize()
}

/// The cubic Hermite spline of glTF Appendix C between key values `v0` (s = 0) and `v1`
/// (s = 1), with the out-tangent `b0` of the first key and the in-tangent `a1` of the second
/// (tangents are per second, hence the factor Δt):
///
/// `p(s) = (2s³ − 3s² + 1) v0 + Δt (s³ − 2s² + s) b0 + (−2s³ + 3s²) v1 + Δt (s³ − s²) a1`.
pub fn hermite(
    v0: Vector4<f64>,
    b0: Vector4<f64>,
    v1: Vector4<f64>,
    a1: Vector4<f64>,
    s: f64,
    dt: f64,
) -> Vector4<f64> {
    let (s2, s3) = (s * s, s * s * s);
    v0 * (2.0 * s3 - 3.0 * s2 + 1.0)
        + b0 * (dt * (s3 - 2.0 * s2 + s))
        + v1 * (-2.0 * s3 + 3.0 * s2)
        + a1 * (dt * (s3 - s2))
}

/// At least one key; times finite and non-decreasing (glTF asks for increasing; equal
/// neighbours are accepted since [`locate`] never interpolates between them).
fn check_times(times: &[f64]) -> Result<(), String> {
    if times.is_empty() {
        return Err("the sampler has no key".to_string());
    }
    if let Some(k) = times.iter().position(|t| !t.is_finite()) {
        return Err(format!("key time {k} is not finite ({})", times[k]));
    }
    if let Some(k) = (1..times.len()).find(|&k| times[k] < times[k - 1]) {
        return Err(format!(
            "key times decrease at key {k} ({} after {})",
            times[k],
            times[k - 1]
        ));
    }
    Ok(())
}

/// Split glTF outputs into (in-tangents, values, out-tangents): with three outputs per key
/// (CUBICSPLINE) they are `a_k, v_k, b_k`; with one, the tangents are empty.
#[allow(clippy::type_complexity)]
fn split_outputs(
    outputs: Vec<Vector4<f64>>,
    per_key: usize,
) -> (Vec<Vector4<f64>>, Vec<Vector4<f64>>, Vec<Vector4<f64>>) {
    if per_key == 1 {
        return (Vec::new(), outputs, Vec::new());
    }
    let column = |c: usize| outputs.iter().skip(c).step_by(3).copied().collect();
    (column(0), column(1), column(2))
}

/// Scale each rotation key to unit length; a zero quaternion is an error naming the key.
fn normalise_quaternions(values: &mut [Vector4<f64>]) -> Result<(), String> {
    for (k, q) in values.iter_mut().enumerate() {
        let norm = q.norm();
        if norm == 0.0 {
            return Err(format!("rotation key {k} is the zero quaternion"));
        }
        *q /= norm;
    }
    Ok(())
}

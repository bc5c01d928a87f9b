//! `gridwarp_naa` through its f32 twin (`src/twin/gridwarp_naa.rs`, the WGSL line for line) on
//! the kernel's own input: under each of the seven arithmetic models a conforming GPU may use,
//! every residual, cell energy, F, JᵀJ and Jᵀr entry lies within the bound derived in
//! `reparam::crosscheck::gridwarp_naa` (the rows `reparam crosscheck gridwarp --variant naa`
//! prints, judged by the same code); each realistic porting mistake (`NaaMutant`) is rejected
//! by the same rows. CPU only.
#![cfg(feature = "gpu")]

use nalgebra::Vector3;
use reparam::crosscheck::gridwarp_naa::{
    evaluation_input, naa_judged_rows, NaaEvaluation, DEPARTURE_LIMIT,
};
use reparam::crosscheck::gridwarp_naa_twin::{twin_outputs, NaaMutant};
use reparam::crosscheck::{Row, Timing, Verdict};
use reparam::gridwarp::scene::{disc_rigidity, flat_rest};
use reparam::gridwarp::{grid_from_rigidity, DeformedJacobian};
use reparam::twin::{with_model, Model};

/// The x-stretch ramp of `plane_stretch`, bent along t and lifted in z: the cells turn
/// non-rectangular (D_s, D_t not orthogonal), which the axis-aligned energy cannot see.
fn bent_stretch(size: usize, sigma: f64) -> DeformedJacobian {
    DeformedJacobian::from_partials(size, move |s: f64, t: f64| {
        let ramp = (3.0 * s * s - 2.0 * s * s * s).clamp(0.0, 1.0);
        (
            Vector3::x() * (1.0 + (sigma - 1.0) * ramp * (0.5 + t)),
            Vector3::y() + Vector3::z() * (0.3 * s),
        )
    })
}

/// The evaluation of the bent stretch (32² fields, a rigid disc, 3 × 3 samples per cell).
fn evaluation(sliding_border: bool) -> NaaEvaluation {
    let rigidity = disc_rigidity(32, &[(0.7, 0.5, 0.15)], 0.1);
    let grid = grid_from_rigidity(&rigidity, 0.5);
    let rest = flat_rest(32, rigidity);
    let frame = bent_stretch(32, 1.9);
    NaaEvaluation::new("bent", &rest, &grid, &frame, (3, 3), sliding_border).unwrap()
}

fn twin_rows(e: &NaaEvaluation, model: Model, mutant: Option<NaaMutant>) -> Vec<Row> {
    let input = evaluation_input(e).unwrap();
    let input = mutant.map_or(input.clone(), |m| m.apply(&input));
    let (residuals, cells) = with_model(model, || twin_outputs(&input));
    naa_judged_rows(e, "bent", &cells, &residuals, Timing::default())
}

#[test]
fn every_model_is_within_the_bound_on_every_row() {
    for sliding in [false, true] {
        let e = evaluation(sliding);
        // The twin's formula evaluated in f64 is the reference's to f64 rounding: a twin that
        // left the formula would show here before any bound is read.
        let departure = e.largest_departure();
        assert!(departure < DEPARTURE_LIMIT, "departure {departure:e}");
        println!("sliding border {sliding}: departure/radius {departure:.2e}");
        println!("| model | row | elements | max error / bound |");
        for model in Model::CHECKED {
            for r in twin_rows(&e, model, None) {
                println!(
                    "| {} | {} | {} | {:.3} |",
                    model.name(),
                    r.kernel,
                    r.errors.count,
                    r.worst_ratio
                );
                assert_eq!(r.verdict, Verdict::Pass, "{}: {r:?}", model.name());
                assert!(r.errors.count > 0, "{}", r.kernel);
            }
        }
    }
}

#[test]
fn every_mutant_is_rejected() {
    let e = evaluation(false);
    println!("| mutant | mistake | rows failed | worst error / bound |");
    for m in NaaMutant::ALL {
        let rows = twin_rows(&e, Model::Nearest, Some(m));
        let failed: Vec<&str> = rows
            .iter()
            .filter(|r| r.fails())
            .map(|r| r.kernel.as_str())
            .collect();
        let worst = rows.iter().map(|r| r.worst_ratio).fold(0.0, f64::max);
        println!(
            "| {m:?} | {} | {} | {worst:.3e} |",
            m.describe(),
            failed.join(", ")
        );
        assert!(!failed.is_empty(), "{m:?} accepted");
    }
}

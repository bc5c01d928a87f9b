//! Issue #53: the many-limbed model that reproduces the thin-part failure, and the removal rule
//! of the coarse levels (`maps::shape`) acting where its docs say and nowhere else.

use reparam::maps::shape::ShapeRule;
use reparam::maps::{build, Features, MapsOptions};
use reparam::mesh::{check_manifold, procedural};

/// The grid of the model as the `maps` command builds it (`procedural:many_limbed`).
const CELLS: usize = 96;

/// The model is a closed manifold facing out, and each limb tip of
/// `many_limbed_tips` is on it: within 0.02 + √3 h of an input vertex, 0.02 the largest tip
/// radius (the tip point lies inside the tapered end at most that far from the surface) and
/// √3 h the diagonal of a grid cell (h = 3.75 / cells along the longest side), within which
/// every point of the extracted surface has a vertex (its cell's edge crossings). A limb that
/// the grid failed to resolve has no vertex near its tip.
#[test]
fn many_limbed_is_a_closed_surface_with_every_tip_on_it() {
    let m = procedural::many_limbed(CELLS);
    check_manifold(&m).unwrap_or_else(|e| panic!("{e}"));
    let volume6: f64 = m
        .faces
        .iter()
        .map(|f| {
            let [a, b, c] = f.map(|v| m.positions[v as usize].coords);
            a.dot(&b.cross(&c))
        })
        .sum();
    assert!(volume6 > 0.0, "faces inwards: {volume6}");
    let h = 3.75 / CELLS as f64;
    let bound = 0.02 + 3f64.sqrt() * h;
    for (i, tip) in procedural::many_limbed_tips().iter().enumerate() {
        let d = m
            .positions
            .iter()
            .map(|p| (p - tip).norm())
            .fold(f64::INFINITY, f64::min);
        assert!(d <= bound, "tip {i} at {tip}: nearest vertex {d} > {bound}");
    }
}

/// The rule orders and defers only on the levels that start with at most
/// `coarse_factor` × `base_size` faces; a deferred vertex was selected and is neither removed
/// nor rejected on that level; the rule defers somewhere on this model (else it would not
/// act); the paper's rule (`shape_rule: None`, `--paper-removal`) never defers.
#[test]
fn the_shape_rule_defers_on_the_coarse_levels_only() {
    let m = procedural::many_limbed(CELLS);
    let rule = ShapeRule::default();
    let options = MapsOptions {
        base_size: 96,
        keep_levels: true,
        ..MapsOptions::default()
    };
    assert_eq!(
        options.shape_rule,
        Some(rule),
        "the default is the shape rule"
    );
    let maps = build(&m, &Features::default(), &options).unwrap();
    let mut deferred = 0;
    for (l, level) in maps.levels.iter().enumerate() {
        if !rule.applies(level.faces.len(), options.base_size) {
            assert!(level.deferred.is_empty(), "level {l}: fine level deferred");
        }
        for v in &level.deferred {
            assert!(level.selected.contains(v), "level {l}: {v} not selected");
            assert!(!level.removed.contains(v), "level {l}: {v} removed");
            assert!(!level.rejected.contains(v), "level {l}: {v} rejected");
        }
        deferred += level.deferred.len();
    }
    assert!(deferred > 0, "the rule deferred nothing");
    let paper = MapsOptions {
        shape_rule: None,
        ..options
    };
    let maps = build(&m, &Features::default(), &paper).unwrap();
    assert!(maps.levels.iter().all(|l| l.deferred.is_empty()));
}

//! The on-screen bound of the rate: coverage against closed forms, and what it caps.

use super::*;

/// 640×480, default window (−4/3, 4/3, −1, 1): 240 pixels per screen unit.
const S: f32 = 240.0;

#[test]
fn perspective_coverage_is_the_projected_square_of_the_bounding_sphere() {
    let ctx = context(DicingHint::Perspective, 60.0, 0.0);
    let d = 1.0 / 30f32.to_radians().tan();
    // A sphere of radius 0.5 at z = 10, on the axis: half-side d·ρ/(z − ρ) screen units.
    let half = d * 0.5 / 9.5;
    let want = (2.0 * half * S).powi(2);
    let got = screen_coverage(&ctx, Vec3::new(0.0, 0.0, 10.0), 0.5);
    assert!((got - want).abs() < 1e-3 * want, "{got} vs {want}");
    // Centred on the right edge of the screen (x = 4/3): half of it is inside.
    let x = 4.0 / 3.0 * 10.0 / d;
    let got = screen_coverage(&ctx, Vec3::new(x, 0.0, 10.0), 0.5);
    assert!((got - want / 2.0).abs() < 1e-2 * want, "{got} vs {}", want / 2.0);
    // Far outside the screen, wholly behind, or reaching the camera plane.
    assert_eq!(screen_coverage(&ctx, Vec3::new(100.0, 0.0, 10.0), 0.5), 0.0);
    assert_eq!(screen_coverage(&ctx, Vec3::new(0.0, 0.0, -0.3), 0.2), 0.0);
    // Beside or below the camera, reaching its plane but outside the frustum: off screen.
    assert_eq!(screen_coverage(&ctx, Vec3::new(0.0, -1.0, 0.05), 0.2), 0.0);
    assert_eq!(screen_coverage(&ctx, Vec3::new(3.0, 0.0, 0.5), 0.6), 0.0);
    assert_eq!(
        screen_coverage(&ctx, Vec3::new(0.0, 0.0, 0.1), 0.2),
        640.0 * 480.0
    );
    assert_eq!(screen_coverage(&ctx, Vec3::ZERO, 10.0), 640.0 * 480.0);
}

#[test]
fn orthographic_and_spherical_coverage_follow_their_closed_forms() {
    let ortho = context(DicingHint::Orthographic, 90.0, 0.0);
    let got = screen_coverage(&ortho, Vec3::new(0.0, 0.0, 5.0), 0.25);
    assert!((got - (0.5 * S).powi(2)).abs() < 1e-2, "{got}");
    assert_eq!(screen_coverage(&ortho, Vec3::new(0.0, 0.0, -5.0), 0.25), 0.0);
    let sph = context(DicingHint::Spherical, 360.0, 0.0);
    // 2s pixels span the field of view (2π): a disc of angular radius asin(ρ/D).
    let alpha = (1.0f32 / 20.0).asin();
    let want = std::f32::consts::PI * (alpha * 2.0 * S / std::f32::consts::TAU).powi(2);
    let got = screen_coverage(&sph, Vec3::new(0.0, 20.0, 0.0), 1.0);
    assert!((got - want).abs() < 1e-3 * want, "{got} vs {want}");
    assert_eq!(
        screen_coverage(&sph, Vec3::new(0.0, 0.5, 0.0), 1.0),
        640.0 * 480.0
    );
}

#[test]
fn the_rate_is_capped_by_coverage_only_where_it_would_explode() {
    let ctx = context(DicingHint::Perspective, 60.0, 0.0);
    // In view: the nearest-point rate σ·s·d/(z − ρ) is kept.
    let d = 1.0 / 30f32.to_radians().tan();
    let in_view = pixels_per_unit(&ctx, Vec3::new(0.0, 0.0, 10.0), 1.0);
    assert!((in_view - S * d / 9.0).abs() < 1e-3 * in_view, "{in_view}");
    // Around the camera: √(F·W·H/(2π²))/ρ instead of the ε floor.
    let around = pixels_per_unit(&ctx, Vec3::ZERO, 10.0);
    let want = (COVERAGE_FACTOR * 640.0 * 480.0 / (2.0 * std::f32::consts::PI.powi(2))).sqrt() / 10.0;
    assert!((around - want).abs() < 1e-3 * want, "{around} vs {want}");
    // Behind: the off-screen allowance.
    let behind = pixels_per_unit(&ctx, Vec3::new(0.0, 0.0, -0.3), 0.2);
    let want = (COVERAGE_FACTOR * OFF_SCREEN_PIXELS / (2.0 * std::f32::consts::PI.powi(2))).sqrt() / 0.2;
    assert!((behind - want).abs() < 1e-3 * want, "{behind} vs {want}");
}

#[test]
fn an_absurd_micropolygon_length_dices_as_the_shortest_allowed() {
    let mut tiny = context(DicingHint::Perspective, 60.0, 10.0);
    tiny.micropolygon_length = 1e-30;
    let mut floor = tiny;
    floor.micropolygon_length = MIN_MICROPOLYGON_LENGTH;
    assert_eq!(count(&unit_sphere(), &tiny), count(&unit_sphere(), &floor));
}

#[test]
fn the_scene_budget_refuses_the_primitive_that_goes_over_and_takes_nothing() {
    let b = TriangleBudget::new(100);
    b.take(60).unwrap();
    assert_eq!(
        b.take(41),
        Err(DiceError::SceneBudget {
            triangles: 41,
            used: 60,
            limit: 100,
            bound: BudgetBound::Option,
        })
    );
    assert_eq!(b.used(), 60);
    b.take(40).unwrap();
    assert!(b.exhausted());
    assert!(b.take(u64::MAX).is_err());
}

#[test]
fn a_memory_limit_lowers_the_budget_to_what_it_holds_and_says_so() {
    let gib = 1u64 << 30;
    // 2 GiB hold (2 GiB − 256 MiB) / 450 bytes.
    let b = TriangleBudget::within_memory(8_000_000, Some((2 * gib, "the address-space limit")));
    assert_eq!(b.limit(), (2 * gib - (256 << 20)) / 450);
    assert_eq!(b.limit(), 4_175_662);
    let message = b.take(5_000_000).unwrap_err().to_string();
    assert!(
        message.contains("budget is 4175662, what 2.0 GiB of memory holds at 450 bytes a triangle (the address-space limit)"),
        "{message}"
    );
    // A limit that holds more than the option leaves the option in charge; so does no limit.
    let roomy = TriangleBudget::within_memory(8_000_000, Some((64 * gib, "MemAvailable")));
    assert_eq!(roomy.limit(), 8_000_000);
    let message = roomy.take(9_000_000).unwrap_err().to_string();
    assert!(message.contains("set by --max-triangles"), "{message}");
    assert_eq!(TriangleBudget::within_memory(100, None).limit(), 100);
    // Less memory than a render's base holds nothing, without underflow.
    assert_eq!(
        TriangleBudget::within_memory(100, Some((1 << 20, "x"))).limit(),
        0
    );
}

//! Tests of [`super`] (shutter.rs).

use super::*;
use crate::distribution::test_samples::Rng;
use proptest::prelude::*;

fn shutter(a: f32, b: f32, opening: [f32; 8]) -> ShutterWarp {
    ShutterWarp::new(&ShutterDesc {
        open_time: a,
        close_time: b,
        opening,
    })
    .expect("valid shutter")
}

const STRAIGHT: [f32; 8] = [0.0, 0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0];
const SLOW_OPEN_SNAP: [f32; 8] = [0.8, 0.1, 0.9, 0.2, 1.0, 1.0, 1.0, 1.0];
const CUSTOM: [f32; 8] = [0.3, 0.7, 0.6, 0.95, 0.2, 0.1, 0.7, 0.6];

/// Reference CDF built independently of the library: the area under each Bézier edge is
/// accumulated in the curve parameter, `∫ y(s)·x'(s) ds`, with Simpson's rule on a fine s grid,
/// giving monotone `(t, area)` knots that are interpolated linearly.
struct ReferenceCdf {
    t: Vec<f64>,
    area: Vec<f64>,
}

impl ReferenceCdf {
    fn new(a: f64, b: f64, o: [f32; 8]) -> Self {
        let o = o.map(f64::from);
        let cubic = |p: [f64; 4], s: f64| {
            let r = 1.0 - s;
            p[0] * r.powi(3) + 3.0 * p[1] * r.powi(2) * s + 3.0 * p[2] * r * s.powi(2) + p[3] * s.powi(3)
        };
        let slope = |p: [f64; 4], s: f64| {
            let r = 1.0 - s;
            3.0 * (p[1] - p[0]) * r.powi(2) + 6.0 * (p[2] - p[1]) * r * s + 3.0 * (p[3] - p[2]) * s.powi(2)
        };
        let mut t = vec![0.0];
        let mut area = vec![0.0];
        let edge = |xs: [f64; 4], ys: [f64; 4], t: &mut Vec<f64>, area: &mut Vec<f64>| {
            let steps = 40_000;
            let h = 1.0 / steps as f64;
            let g = |s: f64| cubic(ys, s) * slope(xs, s);
            let mut acc = *area.last().expect("non-empty");
            for i in 0..steps {
                let s0 = i as f64 * h;
                acc += h / 6.0 * (g(s0) + 4.0 * g(s0 + 0.5 * h) + g(s0 + h));
                t.push(cubic(xs, s0 + h));
                area.push(acc);
            }
        };
        if a > 0.0 {
            edge(
                [0.0, o[0] * a, o[2] * a, a],
                [0.0, o[1], o[3], 1.0],
                &mut t,
                &mut area,
            );
        }
        if b > a {
            t.push(b);
            let last = *area.last().expect("non-empty");
            area.push(last + (b - a));
        }
        if b < 1.0 {
            let w = 1.0 - b;
            edge(
                [b, b + o[4] * w, b + o[6] * w, 1.0],
                [1.0, 1.0 - o[5], 1.0 - o[7], 0.0],
                &mut t,
                &mut area,
            );
        }
        let total = *area.last().expect("non-empty");
        for v in &mut area {
            *v /= total;
        }
        ReferenceCdf { t, area }
    }

    fn at(&self, x: f64) -> f64 {
        let i = self.t.partition_point(|&v| v <= x);
        if i == 0 {
            return 0.0;
        }
        if i >= self.t.len() {
            return 1.0;
        }
        let (t0, t1, a0, a1) = (self.t[i - 1], self.t[i], self.area[i - 1], self.area[i]);
        if t1 > t0 {
            a0 + (a1 - a0) * (x - t0) / (t1 - t0)
        } else {
            a1
        }
    }
}

/// The Kolmogorov–Smirnov statistic of `samples` (sorted in place) against `cdf`.
fn ks_statistic(samples: &mut [f32], cdf: impl Fn(f64) -> f64) -> f64 {
    samples.sort_by(f32::total_cmp);
    let n = samples.len() as f64;
    samples
        .iter()
        .enumerate()
        .map(|(i, &x)| {
            let f = cdf(f64::from(x));
            (f - i as f64 / n).max((i + 1) as f64 / n - f)
        })
        .fold(0.0, f64::max)
}

#[test]
fn default_desc_is_renderman_default() {
    let d = ShutterDesc::default();
    assert_eq!(d.open_time, 0.0);
    assert_eq!(d.close_time, 1.0);
    assert_eq!(d.opening, STRAIGHT);
}

#[test]
fn default_is_identity_bit_for_bit() {
    let mut rng = Rng(1);
    let mut inputs: Vec<f32> = (0..20_000).map(|_| rng.next_f32()).collect();
    inputs.extend([0.0, -0.0, f32::MIN_POSITIVE, 1e-30, 0.5, 0.999_999, ONE_MINUS_ULP]);
    for opening in [STRAIGHT, SLOW_OPEN_SNAP, CUSTOM] {
        let w = shutter(0.0, 1.0, opening);
        assert!(w.is_identity());
        for &u in &inputs {
            assert_eq!(w.warp(u).to_bits(), u.to_bits(), "u = {u}");
        }
        let mut batch = inputs.clone();
        w.warp_batch(&mut batch);
        assert!(batch.iter().zip(&inputs).all(|(a, b)| a.to_bits() == b.to_bits()));
        assert_eq!(w.efficiency(0.0), 1.0);
        assert_eq!(w.efficiency(1.0), 1.0);
        assert_eq!(w.cdf(0.25), 0.25);
    }
    assert!(!shutter(0.01, 1.0, STRAIGHT).is_identity());
    assert!(!shutter(0.0, 0.99, STRAIGHT).is_identity());
}

#[test]
fn trapezoid_efficiency_matches_closed_form() {
    let (a, b) = (0.25f32, 0.75f32);
    let w = shutter(a, b, STRAIGHT);
    for i in 0..=1000 {
        let t = i as f32 / 1000.0;
        let expected = if t < a {
            t / a
        } else if t <= b {
            1.0
        } else {
            (1.0 - t) / (1.0 - b)
        };
        assert!(
            (w.efficiency(t) - expected).abs() < 1e-6,
            "t = {t}: {} vs {expected}",
            w.efficiency(t)
        );
    }
    assert_eq!(w.efficiency(-0.1), 0.0);
    assert_eq!(w.efficiency(1.1), 0.0);
    assert_eq!(w.efficiency(f32::NAN), 0.0);
}

#[test]
fn trapezoid_cdf_matches_closed_form() {
    let (a, b) = (0.25f64, 0.75f64);
    let w = shutter(a as f32, b as f32, STRAIGHT);
    let total = 0.5 * a + (b - a) + 0.5 * (1.0 - b);
    let integral = |t: f64| {
        if t < a {
            t * t / (2.0 * a)
        } else if t <= b {
            0.5 * a + (t - a)
        } else {
            0.5 * a + (b - a) + ((1.0 - b).powi(2) - (1.0 - t).powi(2)) / (2.0 * (1.0 - b))
        }
    };
    for i in 0..=2000 {
        let t = i as f64 / 2000.0;
        let expected = integral(t) / total;
        let got = f64::from(w.cdf(t as f32));
        assert!((got - expected).abs() < 1e-4, "t = {t}: {got} vs {expected}");
    }
}

#[test]
fn linear_close_has_density_two_times_one_minus_t() {
    let w = shutter(0.0, 0.0, STRAIGHT);
    for i in 0..=100 {
        let t = i as f32 / 100.0;
        assert!((w.efficiency(t) - (1.0 - t)).abs() < 1e-6);
        let cdf = 1.0 - (1.0 - f64::from(t)).powi(2);
        assert!((f64::from(w.cdf(t)) - cdf).abs() < 1e-5, "t = {t}");
    }
    let n = 100_000;
    let mean = (0..n)
        .map(|i| f64::from(w.warp((i as f32 + 0.5) / n as f32)))
        .sum::<f64>()
        / n as f64;
    assert!((mean - 1.0 / 3.0).abs() < 1e-4, "mean {mean}");
    // The reverse, a = b = 1: density 2t, mean 2/3.
    let w = shutter(1.0, 1.0, STRAIGHT);
    let mean = (0..n)
        .map(|i| f64::from(w.warp((i as f32 + 0.5) / n as f32)))
        .sum::<f64>()
        / n as f64;
    assert!((mean - 2.0 / 3.0).abs() < 1e-4, "mean {mean}");
}

#[test]
fn efficiency_follows_the_bezier_edges() {
    // Forward evaluation of each edge at its own parameter must agree with the library's
    // inversion: e(x(s)) = y(s).
    let (a, b) = (0.2f64, 0.6f64);
    let w = shutter(a as f32, b as f32, CUSTOM);
    let o = CUSTOM.map(f64::from);
    let cubic = |p: [f64; 4], s: f64| {
        let r = 1.0 - s;
        p[0] * r.powi(3) + 3.0 * p[1] * r.powi(2) * s + 3.0 * p[2] * r * s.powi(2) + p[3] * s.powi(3)
    };
    for i in 0..=200 {
        let s = i as f64 / 200.0;
        let (x, y) = (
            cubic([0.0, o[0] * a, o[2] * a, a], s),
            cubic([0.0, o[1], o[3], 1.0], s),
        );
        assert!(
            (f64::from(w.efficiency(x as f32)) - y).abs() < 1e-4,
            "rise s = {s}"
        );
        let wd = 1.0 - b;
        let x = cubic([b, b + o[4] * wd, b + o[6] * wd, 1.0], s);
        let y = cubic([1.0, 1.0 - o[5], 1.0 - o[7], 0.0], s);
        assert!(
            (f64::from(w.efficiency(x as f32)) - y).abs() < 1e-4,
            "fall s = {s}"
        );
    }
    for t in [0.2f32, 0.3, 0.45, 0.6] {
        assert_eq!(w.efficiency(t), 1.0);
    }
    // RenderMan's example opens slowly: e stays low for most of the interval, then snaps to 1.
    let slow = shutter(1.0, 1.0, SLOW_OPEN_SNAP);
    assert!(slow.efficiency(0.5) < 0.2, "{}", slow.efficiency(0.5));
    assert!(slow.efficiency(0.999) > 0.9, "{}", slow.efficiency(0.999));
}

fn ks_case(a: f32, b: f32, opening: [f32; 8], seed: u64) {
    let w = shutter(a, b, opening);
    let reference = ReferenceCdf::new(f64::from(a), f64::from(b), opening);
    let n = 20_000;
    let critical = 1.36 / (n as f64).sqrt();
    let mut rng = Rng(seed);
    let mut samples: Vec<f32> = (0..n).map(|_| w.warp(rng.next_f32())).collect();
    let d_ref = ks_statistic(&mut samples, |t| reference.at(t));
    assert!(
        d_ref < critical,
        "KS against the reference: D = {d_ref} >= {critical}"
    );
    let d_uniform = ks_statistic(&mut samples, |t| t.clamp(0.0, 1.0));
    assert!(
        d_uniform > critical,
        "KS against uniform has no power: D = {d_uniform}"
    );
    // Stratified samples pin the inverse much tighter: F_ref(warp(u)) = u.
    for i in 0..n {
        let u = (i as f32 + 0.5) / n as f32;
        let err = (reference.at(f64::from(w.warp(u))) - f64::from(u)).abs();
        assert!(err < 2e-4, "u = {u}: F_ref(warp(u)) off by {err}");
    }
}

#[test]
fn ks_slow_open_then_snap() {
    ks_case(1.0, 1.0, SLOW_OPEN_SNAP, 21);
}

#[test]
fn ks_custom_curve() {
    ks_case(0.2, 0.6, CUSTOM, 22);
}

#[test]
fn ks_vertical_tangent_edges() {
    // x control values 1, 0 give x'(s) = 0 at s = 1/2: a vertical tangent in the middle of the edge.
    ks_case(0.4, 0.5, [1.0, 0.2, 0.0, 0.9, 1.0, 0.5, 0.0, 0.5], 23);
}

#[test]
fn cdf_inverts_warp_and_warp_is_monotone() {
    for (a, b, o) in [
        (0.25, 0.75, STRAIGHT),
        (1.0, 1.0, SLOW_OPEN_SNAP),
        (0.2, 0.6, CUSTOM),
        (0.0, 0.3, CUSTOM),
    ] {
        let w = shutter(a, b, o);
        let mut last = -1.0f32;
        for i in 0..5000 {
            let u = i as f32 / 5000.0;
            let t = w.warp(u);
            assert!(t >= last, "not monotone at u = {u}");
            last = t;
            assert!(
                (w.cdf(t) - u).abs() < 1e-4,
                "a = {a}, b = {b}: cdf(warp({u})) = {}",
                w.cdf(t)
            );
        }
    }
}

#[test]
fn extreme_inputs_map_into_the_half_open_interval() {
    for w in [
        shutter(0.0, 1.0, STRAIGHT),
        shutter(0.0, 0.0, STRAIGHT),
        shutter(1.0, 1.0, SLOW_OPEN_SNAP),
    ] {
        for u in [
            0.0f32,
            -0.0,
            -1.0,
            ONE_MINUS_ULP,
            1.0,
            2.0,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ] {
            let t = w.warp(u);
            assert!((0.0..1.0).contains(&t), "warp({u}) = {t}");
        }
        assert!(w.warp(ONE_MINUS_ULP) < 1.0);
    }
    // A very late, very slow opening still has positive area and a usable table.
    let w = shutter(1.0, 1.0, [1.0, 0.0, 1.0, 0.0, 1.0, 1.0, 1.0, 1.0]);
    assert!(w.cdf(0.5) < 0.5);
    assert!((0.0..1.0).contains(&w.warp(0.5)));
}

#[test]
fn gauss_legendre_is_exact_for_degree_nine() {
    let sum: f64 = GL_NODES
        .iter()
        .zip(GL_WEIGHTS)
        .map(|(&x, w)| w * (x.powi(8) + x.powi(9) + 1.0))
        .sum();
    assert!((sum - (2.0 / 9.0 + 2.0)).abs() < 1e-14, "{sum}");
}

#[test]
fn invalid_descs_name_the_parameter() {
    let d = ShutterDesc::default();
    let mut bad_c = d;
    bad_c.opening[0] = 1.5;
    let mut bad_f2 = d;
    bad_f2.opening[7] = f32::NAN;
    let mut negative_e1 = d;
    negative_e1.opening[4] = -0.1;
    let cases = [
        (
            ShutterDesc {
                open_time: 0.6,
                close_time: 0.4,
                ..d
            },
            ["shutterOpenTime", "shutterCloseTime"],
        ),
        (
            ShutterDesc { open_time: -0.1, ..d },
            ["shutterOpenTime", "[0, 1]"],
        ),
        (
            ShutterDesc {
                open_time: f32::NAN,
                ..d
            },
            ["shutterOpenTime", "finite"],
        ),
        (
            ShutterDesc { close_time: 1.5, ..d },
            ["shutterCloseTime", "[0, 1]"],
        ),
        (
            ShutterDesc {
                close_time: f32::INFINITY,
                ..d
            },
            ["shutterCloseTime", "finite"],
        ),
        (bad_c, ["shutteropening[0]", "c1"]),
        (bad_f2, ["shutteropening[7]", "f2"]),
        (negative_e1, ["shutteropening[4]", "[0, 1]"]),
    ];
    for (desc, words) in cases {
        match ShutterWarp::new(&desc) {
            Ok(_) => panic!("{desc:?} accepted"),
            Err(e) => {
                let msg = e.to_string();
                for word in words {
                    assert!(msg.contains(word), "{desc:?}: {msg:?} lacks {word:?}");
                }
            }
        }
    }
    assert!(matches!(
        ShutterWarp::new(&ShutterDesc {
            open_time: 0.6,
            close_time: 0.4,
            ..d
        }),
        Err(ShutterError::OpenAfterClose { .. })
    ));
    assert!(matches!(
        ShutterWarp::new(&bad_c),
        Err(ShutterError::Opening { index: 0, .. })
    ));
}

#[test]
fn warp_is_send_sync_clone() {
    fn check<T: Send + Sync + Clone>() {}
    check::<ShutterWarp>();
    let w = shutter(0.2, 0.6, CUSTOM);
    assert_eq!(w.clone().warp(0.37).to_bits(), w.warp(0.37).to_bits());
}

fn valid_desc() -> impl Strategy<Value = ShutterDesc> {
    (
        0.0f32..=1.0,
        0.0f32..=1.0,
        proptest::array::uniform8(0.0f32..=1.0),
    )
        .prop_map(|(x, y, opening)| ShutterDesc {
            open_time: x.min(y),
            close_time: x.max(y),
            opening,
        })
}

proptest! {
    #[test]
    fn warp_output_is_in_the_half_open_unit_interval(d in valid_desc(), u in 0.0f32..1.0) {
        let w = ShutterWarp::new(&d).expect("valid by construction");
        let t = w.warp(u);
        prop_assert!((0.0..1.0).contains(&t), "warp({}) = {}", u, t);
        let e = w.efficiency(t);
        prop_assert!((0.0..=1.0).contains(&e));
        let c = w.cdf(t);
        prop_assert!((0.0..=1.0).contains(&c));
    }
}

//! State estimation against closed forms and statistics: the joint Kalman filter's steady gain
//! (Riccati equation, Kalata's α-β gains), a hand-computed run, consistency (NEES) on a truth
//! that matches its model, delay compensation, the disturbance state; the encoder sensors and
//! the low-pass baseline; and the filter beating the baseline on a hobby encoder.

#![allow(clippy::unwrap_used)] // test helpers may panic: a panic is a failed test

use chessarm_core::arm::model::JointVector;
use chessarm_core::control::JointState;
use chessarm_core::nalgebra::{Matrix1, Matrix2, Matrix2x3, Matrix3, RowVector2, RowVector3, Vector2, Vector3};
use chessarm_core::sense::kalman::solve_dare;
use chessarm_core::sense::rng::SeededRng;
use chessarm_core::sense::sensors::MAX_DELAY_SAMPLES;
use chessarm_core::sense::{
    EncoderSpec, JointKalman, KalmanSettings, LowPassVelocity, Measurement, SenseError, SensorProfile, Sensors,
};
use std::f64::consts::TAU;

/// The filter's transition and input of the 2-state (`disturbance = false`) or 3-state model,
/// written out again here (independent of the library): `F = [[1, T, T²/2], [0, 1, T], [0, 0, 1]]`
/// or its top-left 2×2 block, `G = (T²/2, T, 0)`.
fn model(t: f64, disturbance: bool) -> (Matrix3<f64>, Vector3<f64>) {
    let f = if disturbance {
        Matrix3::new(1.0, t, t * t / 2.0, 0.0, 1.0, t, 0.0, 0.0, 1.0)
    } else {
        Matrix3::new(1.0, t, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0)
    };
    (f, Vector3::new(t * t / 2.0, t, 0.0))
}

fn settings(acceleration_noise: f64, disturbance_noise: Option<f64>) -> KalmanSettings {
    KalmanSettings { acceleration_noise, disturbance_noise }
}

fn angles<const N: usize>(q: JointVector<N>) -> Measurement<N> {
    Measurement { q, qd: None }
}

/// Relative difference `|a − b| / |b|`.
fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Kalata's steady α-β gains for the discrete white noise acceleration model with position
/// measurements (Kalata 1984): tracking index `λ = σ_a T² / σ_v`,
/// `r = (4 + λ − √(8λ + λ²))/4`, `α = 1 − r²`, `β = 2(2 − α) − 4√(1 − α)`; α and β/T are the
/// a-posteriori gains of q and q̇.
fn kalata(lambda: f64) -> (f64, f64) {
    let r = (4.0 + lambda - (8.0 * lambda + lambda * lambda).sqrt()) / 4.0;
    let alpha = 1.0 - r * r;
    (alpha, 2.0 * (2.0 - alpha) - 4.0 * (1.0 - alpha).sqrt())
}

// ---------------------------------------------------------------------------------------------
// 1. Steady-state gain: Riccati equation and Kalata's closed form
// ---------------------------------------------------------------------------------------------

#[test]
fn steady_gain_matches_the_riccati_solution_and_kalatas_alpha_beta() {
    let (t, sigma_v) = (1e-3, 1e-3);
    let zero = JointVector::<1>::zeros();
    for lambda in [1e-3, 0.1, 1.0, 10.0] {
        let sigma_a = lambda * sigma_v / (t * t);
        let mut filter =
            JointKalman::<1>::new(t, JointVector::<1>::new(sigma_v), None, 0, settings(sigma_a, None)).unwrap();
        // Start far from steady (P₀ = diag(1 rad², 10⁴ rad²/s²)) so that the gain has to converge.
        filter
            .reset_with_covariance(&JointState::at_rest(zero), &Matrix3::from_diagonal(&Vector3::new(1.0, 1e4, 0.0)))
            .unwrap();
        // The Riccati recursion converges like ρ^(2k), ρ the closed-loop pole radius (r of
        // Kalata's formula, 0.98 at λ = 10⁻³): 20 000 updates leave no trace of P₀.
        for _ in 0..20_000 {
            filter.update(&angles(zero), &zero);
        }

        // The Riccati equation of the 2-state filter, from its own matrices.
        let f = Matrix2::new(1.0, t, 0.0, 1.0);
        let g = Vector2::new(t * t / 2.0, t);
        let q = g * g.transpose() * (sigma_a * sigma_a);
        let h = RowVector2::new(1.0, 0.0);
        let r = Matrix1::new(sigma_v * sigma_v);
        let p = solve_dare(&f, &h, &q, &r).unwrap();
        let s = (h * p * h.transpose() + r)[(0, 0)];
        let riccati = f * p * f.transpose() - f * p * h.transpose() * h * p * f.transpose() / s + q;
        let residual = (riccati - p).norm() / p.norm();
        // Doubling stops at a relative change of 10⁻¹³; rounding in 2×2 products is ~10⁻¹⁵.
        assert!(residual <= 1e-12, "λ = {lambda}: DARE residual {residual:e}");
        let k = p * h.transpose() / s;

        let (alpha, beta) = kalata(lambda);
        // The formula's defining relation β²/(1 − α) = λ² (rounding only: 10⁻¹² allows the
        // cancellation in β at small λ, ~10⁻¹⁵/β).
        assert!(relative(beta * beta / (1.0 - alpha), lambda * lambda) <= 1e-10, "λ = {lambda}");

        let gain = filter.gain(0);
        let steady = filter.steady_state_gain(0);
        let differences = [
            relative(gain[(0, 0)], k[0]),
            relative(gain[(1, 0)], k[1]),
            relative(steady[(0, 0)], k[0]),
            relative(steady[(1, 0)], k[1]),
            relative(k[0], alpha),
            relative(k[1] * t, beta),
        ];
        eprintln!(
            "λ = {lambda:e}: α = {alpha:.12}, β = {beta:.12e}; |K − K_dare|/K: filter {:.1e} {:.1e}, steady {:.1e} {:.1e}; DARE vs Kalata {:.1e} {:.1e}; residual {residual:.1e}",
            differences[0], differences[1], differences[2], differences[3], differences[4], differences[5]
        );
        // All three are the same number up to rounding (~10⁻¹² relative at the worst, β's
        // cancellation at λ = 10⁻³); 10⁻⁹ leaves a wide margin and still catches any modelling
        // slip (a wrong Q or G moves the gains by O(1)).
        for (i, difference) in differences.iter().enumerate() {
            assert!(*difference <= 1e-9, "λ = {lambda}: difference {i} = {difference:e}");
        }
        // Steady gains are always below 1 and nonzero: the gains were not trivially equal.
        assert!(alpha > 0.0 && alpha < 1.0 && beta > 0.0);
        // The rate gain is unused without a rate sensor.
        assert_eq!(gain.column(1).norm(), 0.0);
    }
}

#[test]
fn riccati_solution_of_the_three_state_and_rate_sensor_filters() {
    let t = 1e-3;
    // 3 states, angle only; 2 states, angle and rate; 3 states, angle and rate.
    let (f3, g3) = model(t, true);
    let q3 = g3 * g3.transpose() * 4.0 + Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, 0.01));
    let h3 = RowVector3::new(1.0, 0.0, 0.0);
    let p3 = solve_dare(&f3, &h3, &q3, &Matrix1::new(1e-6)).unwrap();
    let s3 = (h3 * p3 * h3.transpose())[(0, 0)] + 1e-6;
    let riccati3 = f3 * p3 * f3.transpose() - f3 * p3 * h3.transpose() * h3 * p3 * f3.transpose() / s3 + q3;
    assert!((riccati3 - p3).norm() <= 1e-12 * p3.norm(), "3-state residual {:e}", (riccati3 - p3).norm());

    let f2 = Matrix2::new(1.0, t, 0.0, 1.0);
    let g2 = Vector2::new(t * t / 2.0, t);
    let q2 = g2 * g2.transpose() * 4.0;
    let r2 = Matrix2::new(1e-6, 0.0, 0.0, 1e-2);
    let p2 = solve_dare(&f2, &Matrix2::identity(), &q2, &r2).unwrap();
    let riccati2 = f2 * p2 * f2.transpose() - f2 * p2 * (p2 + r2).try_inverse().unwrap() * p2 * f2.transpose() + q2;
    assert!((riccati2 - p2).norm() <= 1e-12 * p2.norm());

    // The filter's gain after many updates from a far start equals its steady gain, for every
    // variant (the filter's own P∞ and K∞, checked against the equation above).
    let zero = JointVector::<1>::zeros();
    for (rate, disturbance) in [(false, true), (true, false), (true, true)] {
        let rate_std = rate.then(|| JointVector::<1>::new(0.1));
        let mut filter = JointKalman::<1>::new(
            t,
            JointVector::<1>::new(1e-3),
            rate_std,
            0,
            settings(2.0, disturbance.then_some(0.1)),
        )
        .unwrap();
        let h = if rate {
            Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0)
        } else {
            Matrix2x3::new(1.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        };
        let r = Matrix2::new(1e-6, 0.0, 0.0, if rate { 1e-2 } else { 1.0 });
        let (f, g) = model(t, disturbance);
        let q = g * g.transpose() * 4.0
            + Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, if disturbance { 0.01 } else { 0.0 }));
        let p = filter.steady_state_covariance(0);
        let s = h * p * h.transpose() + r;
        let riccati =
            f * p * f.transpose() - f * p * h.transpose() * s.try_inverse().unwrap() * h * p * f.transpose() + q;
        assert!((riccati - p).norm() <= 1e-12 * p.norm(), "rate {rate}, disturbance {disturbance}");
        // At reset the filter is at its steady covariance: its first gain is the steady one.
        filter.update(&Measurement { q: zero, qd: rate.then_some(zero) }, &zero);
        assert!((filter.gain(0) - filter.steady_state_gain(0)).norm() <= 1e-12 * filter.steady_state_gain(0).norm());
        filter
            .reset_with_covariance(&JointState::at_rest(zero), &Matrix3::from_diagonal(&Vector3::new(1.0, 1e2, 1e2)))
            .unwrap();
        // The closed-loop pole radius here is at most 0.971 (ρ of (I − K∞H)F): ρ^(2k) leaves
        // nothing of P₀ after 50 000 updates, only rounding (10⁻¹² relative).
        for _ in 0..50_000 {
            filter.update(&Measurement { q: zero, qd: rate.then_some(zero) }, &zero);
        }
        let difference = (filter.gain(0) - filter.steady_state_gain(0)).norm() / filter.steady_state_gain(0).norm();
        assert!(difference <= 1e-9, "rate {rate}, disturbance {disturbance}: {difference:e}");
        assert_eq!(filter.gain(0).column(1).norm() > 0.0, rate, "the rate column is used iff there is a rate");
    }

    // No stabilising solution without process noise on a marginally stable F: an error.
    assert!(solve_dare(&f2, &RowVector2::new(1.0, 0.0), &Matrix2::zeros(), &Matrix1::new(1.0)).is_err());
    // R must be positive definite.
    assert!(solve_dare(&f2, &RowVector2::new(1.0, 0.0), &q2, &Matrix1::new(0.0)).is_err());
}

// ---------------------------------------------------------------------------------------------
// 2. Three steps by hand
// ---------------------------------------------------------------------------------------------

/// Three predict/update steps worked out by hand in exact fractions, in the style of GTSAM's
/// `testKalmanFilter`. `T = 1 s`, `σ_a = 2 rad/s²`, `σ_v = 1 rad`, `P₀ = I`, `x₀ = 0`, inputs
/// `u = 2, 2, −2`, readings `z = 2, 3, 5`. So `G = (1/2, 1)`, `Q = 4 G Gᵀ = [[1, 2], [2, 4]]`,
/// and with `P = [[a, b], [b, c]]`, `F P Fᵀ = [[a + 2b + c, b + c], [b + c, c]]`.
///
/// Step 1: `P⁻ = [[1+0+1, 1], [1, 1]] + Q = [[3, 3], [3, 5]]`, `S = 3 + 1 = 4`,
/// `K = (3/4, 3/4)`; `x⁻ = G·2 = (1, 2)`, innovation `2 − 1 = 1`, `x = (7/4, 11/4)`;
/// `P = P⁻ − K Kᵀ S = [[3 − 9/4, 3 − 9/4], [3 − 9/4, 5 − 9/4]] = [[3/4, 3/4], [3/4, 11/4]]`.
///
/// Step 2: `F P Fᵀ = [[3/4 + 3/2 + 11/4, 7/2], [7/2, 11/4]] = [[5, 7/2], [7/2, 11/4]]`,
/// `P⁻ = [[6, 11/2], [11/2, 27/4]]`, `S = 7`, `K = (6/7, 11/14)`;
/// `x⁻ = (7/4 + 11/4 + 1, 11/4 + 2) = (11/2, 19/4)`, innovation `3 − 11/2 = −5/2`,
/// `x = (11/2 − 15/7, 19/4 − 55/28) = (47/14, 39/14)`;
/// `P = [[6 − 36/7, 11/2 − 33/7], [·, 27/4 − 121/28]] = [[6/7, 11/14], [11/14, 17/7]]`.
///
/// Step 3: `F P Fᵀ = [[6/7 + 11/7 + 17/7, 11/14 + 17/7], [·, 17/7]] = [[34/7, 45/14], [45/14, 17/7]]`,
/// `P⁻ = [[41/7, 73/14], [73/14, 45/7]]`, `S = 48/7`, `K = (41/48, 73/96)`;
/// `x⁻ = (47/14 + 39/14 − 1, 39/14 − 2) = (36/7, 11/14)`, innovation `5 − 36/7 = −1/7`,
/// `x = (36/7 − 41/336, 11/14 − 73/672) = (241/48, 65/96)`;
/// `P = P⁻ (1 − 41/48)` in its first row, so `[[41/48, 73/96], [73/96, 45/7 − 73²/1344]]
/// = [[41/48, 73/96], [73/96, 473/192]]`.
#[test]
fn three_steps_match_the_hand_computation() {
    let mut filter = JointKalman::<1>::new(1.0, JointVector::<1>::new(1.0), None, 0, settings(2.0, None)).unwrap();
    filter.reset_with_covariance(&JointState::at_rest(JointVector::<1>::zeros()), &Matrix3::identity()).unwrap();
    let expected = [
        ((7.0 / 4.0, 11.0 / 4.0), (3.0 / 4.0, 3.0 / 4.0, 11.0 / 4.0), (3.0 / 4.0, 3.0 / 4.0)),
        ((47.0 / 14.0, 39.0 / 14.0), (6.0 / 7.0, 11.0 / 14.0, 17.0 / 7.0), (6.0 / 7.0, 11.0 / 14.0)),
        ((241.0 / 48.0, 65.0 / 96.0), (41.0 / 48.0, 73.0 / 96.0, 473.0 / 192.0), (41.0 / 48.0, 73.0 / 96.0)),
    ];
    for ((u, z), ((q, qd), (pqq, pqv, pvv), (kq, kv))) in
        [(2.0, 2.0), (2.0, 3.0), (-2.0, 5.0)].into_iter().zip(expected)
    {
        let estimate = filter.update(&angles(JointVector::<1>::new(z)), &JointVector::<1>::new(u));
        let p = filter.covariance(0);
        let k = filter.gain(0);
        // Numbers of order 1 through a handful of operations: rounding is ~10⁻¹⁵; the Joseph
        // form differs from `P⁻ − K Kᵀ S` only by rounding.
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12;
        assert!(close(estimate.q[0], q) && close(estimate.qd[0], qd), "x = ({}, {})", estimate.q[0], estimate.qd[0]);
        assert!(
            close(p[(0, 0)], pqq) && close(p[(0, 1)], pqv) && close(p[(1, 0)], pqv) && close(p[(1, 1)], pvv),
            "P = {p}"
        );
        assert!(close(k[(0, 0)], kq) && close(k[(1, 0)], kv), "K = {k}");
        // No disturbance state: its row and column stay zero.
        assert_eq!(p.row(2).norm() + p.column(2).norm() + k.row(2).norm(), 0.0);
    }
}

// ---------------------------------------------------------------------------------------------
// 3. Consistency (NEES)
// ---------------------------------------------------------------------------------------------

/// The standard normal quantile at 0.975.
const Z_975: f64 = 1.959_963_984_540_054;

/// The `p` quantile of χ²(ν) by the Wilson–Hilferty approximation,
/// `ν (1 − 2/(9ν) + z_p √(2/(9ν)))³` (z_p the normal quantile): a relative error well under 1 %
/// for ν ≥ 10, and of order 10⁻⁴ at the ν of 200 to 300 used here (checked below against the
/// tabulated χ²(100) quantiles).
fn chi_square_quantile(nu: f64, z: f64) -> f64 {
    let c = 2.0 / (9.0 * nu);
    nu * (1.0 - c + z * c.sqrt()).powi(3)
}

#[test]
fn wilson_hilferty_matches_tabulated_quantiles() {
    // χ²(100): 0.025 quantile 74.222, 0.975 quantile 129.561 (standard tables).
    assert!(relative(chi_square_quantile(100.0, -Z_975), 74.222) < 1e-3);
    assert!(relative(chi_square_quantile(100.0, Z_975), 129.561) < 1e-3);
    // χ²(10): 3.247 and 20.483: still within 1 %.
    assert!(relative(chi_square_quantile(10.0, -Z_975), 3.247) < 1e-2);
    assert!(relative(chi_square_quantile(10.0, Z_975), 20.483) < 1e-2);
}

/// One NEES experiment: its filter and what was found.
#[derive(Debug, Clone, Copy)]
struct NeesCase {
    disturbance: Option<f64>,
    delay: usize,
    rate_std: Option<f64>,
    /// The filter assumes σ_a times this (1: the truth's).
    assumed_noise_scale: f64,
}

#[derive(Debug)]
struct NeesResult {
    /// Fraction of steps whose summed NEES lies in the two-sided 95 % χ² interval.
    inside: f64,
    /// NEES averaged over steps, joints and runs, and the standard error of that average from
    /// the spread of the independent runs' averages.
    mean: f64,
    standard_error: f64,
    states: usize,
}

/// NEES `eᵀ P⁻¹ e` over the first `n` states.
fn nees(error: &Vector3<f64>, p: &Matrix3<f64>, n: usize) -> f64 {
    if n == 3 {
        let solved = p.cholesky().unwrap().solve(error);
        error.dot(&solved)
    } else {
        let e = Vector2::new(error[0], error[1]);
        let block: Matrix2<f64> = p.fixed_view::<2, 2>(0, 0).into_owned();
        e.dot(&block.cholesky().unwrap().solve(&e))
    }
}

/// `runs` Monte-Carlo runs of `steps` updates of a 2-joint filter on a truth that is its model
/// exactly: `x_{i+1} = F x_i + G (u_i + σ_a n) + e₃ σ_d n'`, readings `q + σ_v n` (and
/// `q̇ + σ_r n`), starting from `x ~ N(x̂₀, P₀)` at the filter's start sample `−δ−1`. The
/// inputs are large (uniform ±1000 rad/s², five times σ_a) and known to the filter, so that
/// one sample's slip in using them would show as a gross inconsistency.
fn nees_experiment(case: NeesCase, runs: usize, steps: usize, seed: u64) -> NeesResult {
    const JOINTS: usize = 2;
    let t = 1e-3;
    let sigma_a = 200.0;
    let sigma_v = [1e-3, 2e-3];
    let delay = case.delay;
    let has_d = case.disturbance.is_some();
    let n = if has_d { 3 } else { 2 };
    let (f, g) = model(t, has_d);
    let sigma_d = case.disturbance.unwrap_or(0.0);
    let mut step_sums = vec![0.0; steps];
    let mut run_means = Vec::with_capacity(runs);
    for run in 0..runs {
        let mut rng = SeededRng::new(seed.wrapping_mul(1000).wrapping_add(run as u64));
        let mut filter = JointKalman::<JOINTS>::new(
            t,
            JointVector::<JOINTS>::from(sigma_v),
            case.rate_std.map(JointVector::<JOINTS>::repeat),
            delay,
            settings(sigma_a * case.assumed_noise_scale, case.disturbance),
        )
        .unwrap();
        let start = JointState { q: JointVector::<JOINTS>::new(0.3, -0.7), qd: JointVector::<JOINTS>::new(0.5, 0.0) };
        filter.reset(&start);
        // The truth at sample −δ−1 (index 0 below), drawn about the filter's start.
        let total = steps + delay + 1;
        let mut truth = vec![[Vector3::zeros(); JOINTS]; total];
        let mut inputs = vec![JointVector::<JOINTS>::zeros(); total];
        let mut readings = vec![Measurement { q: JointVector::<JOINTS>::zeros(), qd: None }; total];
        for (j, first) in truth[0].iter_mut().enumerate() {
            let p0 = filter.filter_covariance(j);
            let mean = Vector3::new(start.q[j], start.qd[j], 0.0);
            let draw = Vector3::new(rng.normal(), rng.normal(), rng.normal());
            *first = if n == 3 {
                mean + p0.cholesky().unwrap().l() * draw
            } else {
                let l = p0.fixed_view::<2, 2>(0, 0).into_owned().cholesky().unwrap().l();
                let offset = l * Vector2::new(draw[0], draw[1]);
                mean + Vector3::new(offset[0], offset[1], 0.0)
            };
        }
        // Index i is sample i − δ − 1. Inputs before sample −1 are the zeros the filter's ring
        // starts with; from sample −1 (index δ) on they are random.
        for i in 0..total {
            if i >= delay {
                inputs[i] = JointVector::<JOINTS>::from_fn(|_, _| rng.uniform(-1000.0, 1000.0));
            }
            let mut reading = readings[i];
            let mut rate = JointVector::<JOINTS>::zeros();
            for j in 0..JOINTS {
                reading.q[j] = truth[i][j][0] + sigma_v[j] * rng.normal();
                if let Some(sigma_r) = case.rate_std {
                    rate[j] = truth[i][j][1] + sigma_r * rng.normal();
                }
            }
            reading.qd = case.rate_std.map(|_| rate);
            readings[i] = reading;
            if i + 1 < total {
                for j in 0..JOINTS {
                    let w =
                        g * (inputs[i][j] + sigma_a * rng.normal()) + Vector3::new(0.0, 0.0, sigma_d * rng.normal());
                    truth[i + 1][j] = f * truth[i][j] + w;
                }
            }
        }
        let mut run_sum = 0.0;
        for (k, step_sum) in step_sums.iter_mut().enumerate() {
            // Update k (sample k) gets the reading of sample k − δ (index k + 1) and u_{k−1}
            // (index k + δ); it estimates sample k (index k + δ + 1).
            let estimate = filter.update(&readings[k + 1], &inputs[k + delay]);
            let disturbance = filter.disturbance();
            for j in 0..JOINTS {
                let x = truth[k + delay + 1][j];
                let error = Vector3::new(estimate.q[j] - x[0], estimate.qd[j] - x[1], disturbance[j] - x[2]);
                let value = nees(&error, &filter.covariance(j), n);
                *step_sum += value;
                run_sum += value;
            }
        }
        run_means.push(run_sum / (steps * JOINTS) as f64);
    }
    let nu = (n * JOINTS * runs) as f64;
    let (low, high) = (chi_square_quantile(nu, -Z_975), chi_square_quantile(nu, Z_975));
    let inside = step_sums.iter().filter(|s| (low..=high).contains(*s)).count() as f64 / steps as f64;
    let mean = run_means.iter().sum::<f64>() / runs as f64;
    let variance = run_means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (runs - 1) as f64;
    NeesResult { inside, mean, standard_error: (variance / runs as f64).sqrt(), states: n }
}

/// Under consistency each step's NEES summed over the M runs and 2 joints is χ²(n·2M), so it
/// falls in the two-sided 95 % interval with probability 0.95 at every step. Successive steps
/// are correlated through the filter's error dynamics: the closed-loop pole radius ρ of
/// `(I − K∞H)F` is 0.73–0.80 for the 2-state cases (λ = σ_a T²/σ_v = 0.1–0.2), 0.69 with the
/// rate sensor and 0.905 for the 3-state ones, so the NEES decorrelates over
/// τ ≈ 1/(1 − ρ²) ≤ 6 samples. The fraction inside over K = 2000 steps then has a standard
/// deviation of about √(0.95·0.05·(1 + 2τ)/K) ≤ 0.018: 0.90 is about 3 of them below the
/// expected 0.95, and far above what an inconsistent filter achieves (0 for the overconfident
/// one at the end). The grand mean has the
/// standard error of the 50 independent runs' means; it must lie within 4 of them of n, and
/// that standard error must be small (≤ 3 % of n) for the band to mean anything.
#[test]
fn filter_is_consistent_on_its_own_model() {
    let cases = [
        NeesCase { disturbance: None, delay: 0, rate_std: None, assumed_noise_scale: 1.0 },
        NeesCase { disturbance: Some(20.0), delay: 0, rate_std: None, assumed_noise_scale: 1.0 },
        NeesCase { disturbance: None, delay: 1, rate_std: None, assumed_noise_scale: 1.0 },
        NeesCase { disturbance: None, delay: 3, rate_std: None, assumed_noise_scale: 1.0 },
        NeesCase { disturbance: Some(20.0), delay: 1, rate_std: None, assumed_noise_scale: 1.0 },
        NeesCase { disturbance: Some(20.0), delay: 3, rate_std: None, assumed_noise_scale: 1.0 },
        NeesCase { disturbance: None, delay: 1, rate_std: Some(0.5), assumed_noise_scale: 1.0 },
    ];
    for (i, case) in cases.into_iter().enumerate() {
        let result = nees_experiment(case, 50, 2000, 17 + i as u64);
        let n = result.states as f64;
        eprintln!(
            "NEES {case:?}: inside 95 % interval {:.3} of steps, mean {:.4} ± {:.4} (n = {n})",
            result.inside, result.mean, result.standard_error
        );
        assert!(result.inside >= 0.90, "{case:?}: {result:?}");
        assert!((result.mean - n).abs() <= 4.0 * result.standard_error, "{case:?}: {result:?}");
        assert!(result.standard_error <= 0.03 * n, "{case:?}: {result:?}");
    }
    // The test has teeth: a filter that assumes half the truth's process noise is overconfident.
    let overconfident = nees_experiment(
        NeesCase { disturbance: None, delay: 1, rate_std: None, assumed_noise_scale: 0.5 },
        50,
        2000,
        99,
    );
    eprintln!("NEES with σ_a halved: inside {:.3}, mean {:.3}", overconfident.inside, overconfident.mean);
    assert!(overconfident.inside < 0.5 && overconfident.mean > 1.2 * 2.0, "{overconfident:?}");
}

// ---------------------------------------------------------------------------------------------
// 4. Delay compensation
// ---------------------------------------------------------------------------------------------

/// The delayed filter is exactly the undelayed one, run δ samples behind on the same readings,
/// carried forward through the inputs since: checks the ring's indexing one sample at a time.
#[test]
fn delayed_filter_is_the_undelayed_one_carried_forward() {
    let t = 1e-3;
    let (f, g) = model(t, true);
    for delay in [1usize, 2, 5] {
        let make = |delay| {
            JointKalman::<1>::new(t, JointVector::<1>::new(1e-3), None, delay, settings(5.0, Some(0.5))).unwrap()
        };
        let (mut delayed, mut undelayed) = (make(delay), make(0));
        let start = JointState { q: JointVector::<1>::new(0.2), qd: JointVector::<1>::new(0.0) };
        delayed.reset(&start);
        undelayed.reset(&start);
        let mut rng = SeededRng::new(5);
        // u[i] is u_{i−δ−1}: zeros up to u_{−2} (the ring's start), then random.
        let steps = 200;
        let inputs: Vec<f64> =
            (0..steps + delay + 1).map(|i| if i >= delay { rng.uniform(-50.0, 50.0) } else { 0.0 }).collect();
        let readings: Vec<f64> = (0..steps).map(|k| 0.2 + 1e-3 * k as f64 + 1e-3 * rng.normal()).collect();
        let mut history = Vec::new();
        for k in 0..steps {
            // The delayed filter at sample k gets reading k (its sample k − δ) and u_{k−1}; the
            // undelayed one, δ samples behind, gets the same reading and u_{k−δ−1}.
            let reading = angles(JointVector::<1>::new(readings[k]));
            let out = delayed.update(&reading, &JointVector::<1>::new(inputs[k + delay]));
            let behind = undelayed.update(&reading, &JointVector::<1>::new(inputs[k]));
            history.push(behind);
            // Carry the undelayed estimate forward through u_{k−δ} … u_{k−1}.
            let mut x = Vector3::new(behind.q[0], behind.qd[0], undelayed.disturbance()[0]);
            let mut p = undelayed.covariance(0);
            for i in 1..=delay {
                x = f * x + g * inputs[k + i];
                p = f * p * f.transpose()
                    + g * g.transpose() * 25.0
                    + Matrix3::from_diagonal(&Vector3::new(0.0, 0.0, 0.25));
            }
            // Same operations in a different order: rounding only (values of order 1).
            assert!((out.q[0] - x[0]).abs() <= 1e-10, "δ {delay}, k {k}: {} vs {}", out.q[0], x[0]);
            assert!((out.qd[0] - x[1]).abs() <= 1e-8, "δ {delay}, k {k}: {} vs {}", out.qd[0], x[1]);
            assert!((delayed.disturbance()[0] - x[2]).abs() <= 1e-8);
            assert!((delayed.covariance(0) - p).norm() <= 1e-9 * p.norm(), "δ {delay}, k {k}");
            assert!((delayed.filter_covariance(0) - undelayed.filter_covariance(0)).norm() <= 1e-12);
            assert_eq!(delayed.estimate(), out);
        }
        // The inputs mattered: the carried-forward estimate differs from the one behind.
        let last = history[steps - 1];
        assert!((delayed.estimate().qd[0] - last.qd[0]).abs() > 1e-3);
    }
}

/// A truth of constant commanded acceleration from rest, `q_k = q₀ + a (kT)²/2`, read by fine
/// encoders (the servo profile's, 0.048 mrad) two samples late. The filter with delay 2 tracks
/// `x_k`; the reading lags by `2T q̇` (≈ 8 mrad at the second half's RMS rate of 3.9 rad/s), and
/// filters told the wrong delay are off by `T q̇`.
#[test]
fn delay_compensation_tracks_the_present_state() {
    let t = 1e-3;
    let accelerations = [2.0, -3.0];
    let mut profile = SensorProfile::<2>::servo();
    profile.delay_samples = 2;
    let steps = 2000;
    let run = |filter_delay: usize| {
        let mut sensors = Sensors::new(profile.clone(), 11).unwrap();
        let q0 = JointVector::<2>::new(0.1, -0.4);
        let initial = JointState::at_rest(q0);
        let due = sensors.reset(&initial);
        let mut filter =
            JointKalman::<2>::new(t, profile.angle_std(), None, filter_delay, settings(1.0, None)).unwrap();
        filter.reset(&JointState { q: due.q, qd: initial.qd });
        let (mut filter_error, mut lag_error, mut rate_error) = (0.0, 0.0, 0.0);
        let mut rate_sigma = 0.0f64;
        for k in 0..steps {
            let time = k as f64 * t;
            let state = JointState {
                q: JointVector::<2>::from_fn(|j, _| q0[j] + 0.5 * accelerations[j] * time * time),
                qd: JointVector::<2>::from_fn(|j, _| accelerations[j] * time),
            };
            let measurement = sensors.measure(&state);
            // u_{k−1}: the acceleration starts at sample 0, so u_{−1} = 0.
            let applied = if k == 0 { JointVector::<2>::zeros() } else { JointVector::<2>::from(accelerations) };
            let estimate = filter.update(&measurement, &applied);
            if k >= steps / 2 {
                filter_error += (estimate.q - state.q).norm_squared();
                lag_error += (measurement.q - state.q).norm_squared();
                rate_error += (estimate.qd - state.qd).norm_squared();
                rate_sigma = rate_sigma.max(filter.covariance(0)[(1, 1)].sqrt());
            }
        }
        let samples = (steps / 2 * 2) as f64;
        ((filter_error / samples).sqrt(), (lag_error / samples).sqrt(), (rate_error / samples).sqrt(), rate_sigma)
    };
    let (error, lag, rate_error, rate_sigma) = run(2);
    eprintln!(
        "delay 2: RMS angle error of the filter {error:.3e} rad, of the raw reading {lag:.3e} rad; rate {rate_error:.3e} rad/s (filter σ {rate_sigma:.3e})"
    );
    // The lag error is 2T q̇: q̇ = a t over t ∈ [1, 2) s has an RMS of |a| √(7/3), so over the
    // two joints 2 ms × √((4 + 9)/2 · 7/3) rad/s = 7.79 mrad (the encoder's 0.03 mrad aside).
    assert!(relative(lag, 7.79e-3) < 0.02, "lag {lag}");
    // The filter's model is exact here, so only the encoder noise σ_q = 0.028 mrad remains, and
    // the filter smooths it: its error is below σ_q, 0.5 % of the lag. 5 % is a wide margin
    // that a one-sample slip (≈ 3 mrad, 50 %) could never meet.
    assert!(error < 0.05 * lag, "filter {error} vs lag {lag}");
    assert!(error < profile.angle_std()[0], "filter {error} vs σ_q {}", profile.angle_std()[0]);
    // Rate: the truth has no process noise, so the filter's covariance bounds its error (the
    // error is a measurement-noise part, matched to R, plus a process-noise part, here absent).
    assert!(rate_error <= rate_sigma, "rate error {rate_error} vs σ {rate_sigma}");
    for wrong in [1, 3] {
        let (wrong_error, _, _, _) = run(wrong);
        eprintln!("  filter told delay {wrong}: RMS angle error {wrong_error:.3e} rad");
        // Off by one sample: T q̇ ≈ 3 mrad, at least 10× the right filter's error.
        assert!(wrong_error > 10.0 * error && wrong_error > 0.3 * lag, "delay {wrong}: {wrong_error}");
    }
}

// ---------------------------------------------------------------------------------------------
// 5. Disturbance state
// ---------------------------------------------------------------------------------------------

/// A constant unknown acceleration `d` on the truth (`q̈ = u + d`, u a known sinusoidal
/// command), read by the hobby profile's encoders (1 sample late). The 3-state filter finds d
/// and its rate estimate has no bias; the 2-state filter, which cannot know d, lags with a
/// steady rate bias.
#[test]
fn disturbance_state_estimates_a_constant_unknown_acceleration() {
    let t = 1e-3;
    let disturbance = [3.0, -1.5];
    let profile = SensorProfile::<2>::hobby();
    let steps = 10_000;
    let window = steps / 2; // the last 5 s, after convergence (the d loop settles in ~1 s)
    let run = |disturbance_noise: Option<f64>| {
        let mut sensors = Sensors::new(profile.clone(), 23).unwrap();
        let mut state = JointState::at_rest(JointVector::<2>::new(0.0, 0.5));
        let due = sensors.reset(&state);
        let mut filter =
            JointKalman::<2>::new(t, profile.angle_std(), None, 1, settings(0.5, disturbance_noise)).unwrap();
        filter.reset(&JointState { q: due.q, qd: state.qd });
        let (mut d_sum, mut d_square, mut rate_sum) =
            (JointVector::<2>::zeros(), JointVector::<2>::zeros(), JointVector::<2>::zeros());
        let mut applied = JointVector::<2>::zeros();
        for k in 0..steps {
            let measurement = sensors.measure(&state);
            let estimate = filter.update(&measurement, &applied);
            if k >= steps - window {
                let d_error = filter.disturbance() - JointVector::<2>::from(disturbance);
                d_sum += d_error;
                d_square += d_error.component_mul(&d_error);
                rate_sum += estimate.qd - state.qd;
            }
            // The command over [k, k+1], and the truth's exact step with u + d held.
            let time = k as f64 * t;
            let u = JointVector::<2>::new(2.0 * (TAU * 0.5 * time).sin(), -(TAU * 0.3 * time).cos());
            for j in 0..2 {
                let acceleration = u[j] + disturbance[j];
                state.q[j] += state.qd[j] * t + 0.5 * acceleration * t * t;
                state.qd[j] += acceleration * t;
            }
            applied = u;
        }
        let w = window as f64;
        (d_sum / w, (d_square / w).map(f64::sqrt), rate_sum / w, filter)
    };
    let (d_bias, d_rms, rate_bias, filter) = run(Some(0.01));
    let (_, _, lag_bias, _) = run(None);
    for j in 0..2 {
        let p = filter.covariance(j);
        let (sigma_d, sigma_rate) = (p[(2, 2)].sqrt(), p[(1, 1)].sqrt());
        eprintln!(
            "joint {}: d = {}: d̂ − d mean {:.4}, RMS {:.4} (filter σ_d {sigma_d:.4}); q̇ bias {:.2e} (σ {sigma_rate:.2e}); 2-state q̇ bias {:.3e} rad/s",
            j + 1,
            disturbance[j],
            d_bias[j],
            d_rms[j],
            rate_bias[j],
            lag_bias[j]
        );
        // The truth has no process noise and the encoder error has the filter's R, so the
        // filter's steady covariance bounds its actual error covariance (with fixed gains the
        // error is a sum of a measurement-noise part, matched, and a process-noise part, here
        // absent). Then |d̂ − d| averaged is well inside 3 σ_d, and so is its RMS.
        assert!(d_bias[j].abs() <= 3.0 * sigma_d && d_rms[j] <= 3.0 * sigma_d, "joint {j}");
        // And the bound means something: 3 σ_d is under a quarter of |d| (an estimate of 0 fails).
        assert!(3.0 * sigma_d <= 0.25 * disturbance[j].abs(), "σ_d {sigma_d}");
        // Unbiased rate: the mean over 5000 samples of an error whose σ is at most σ_rate, and
        // whose correlation time is ~60 samples (closed-loop pole radius 0.984), has a σ of
        // about σ_rate √(2·60/5000) ≈ σ_rate/6; 1 σ_rate is a loose bound that still sits more
        // than ten times below the 2-state filter's bias.
        assert!(rate_bias[j].abs() <= sigma_rate, "joint {j}: rate bias {}", rate_bias[j]);
        assert!(lag_bias[j].abs() > 10.0 * sigma_rate, "the 2-state filter should lag: {}", lag_bias[j]);
    }
}

// ---------------------------------------------------------------------------------------------
// 6. Sensors and the low-pass baseline
// ---------------------------------------------------------------------------------------------

#[test]
fn encoder_readings_lie_on_the_grid_with_the_configured_error_statistics() {
    let samples = 200_000;
    for (base, offset) in
        [(SensorProfile::<1>::hobby(), 0.0), (SensorProfile::<1>::servo(), 0.0), (SensorProfile::<1>::hobby(), 0.004)]
    {
        let mut profile = base;
        profile.delay_samples = 0;
        profile.encoders[0].offset = offset;
        let encoder = profile.encoders[0];
        let resolution = encoder.resolution();
        let mut sensors = Sensors::new(profile.clone(), 3).unwrap();
        let mut angles = SeededRng::new(4);
        let (mut sum, mut square) = (0.0, 0.0);
        for _ in 0..samples {
            let q = angles.uniform(-3.0, 3.0);
            let reading = sensors.measure(&JointState::at_rest(JointVector::<1>::new(q))).q[0];
            let counts = reading / resolution;
            // At most 2¹⁷ counts: a float's quotient is exact to ~10⁻¹¹ counts.
            assert!((counts - counts.round()).abs() <= 1e-9, "{}: {reading} is {counts} counts", profile.name);
            let error = reading - q;
            sum += error;
            square += error * error;
        }
        let n = samples as f64;
        let mean = sum / n;
        let variance = (square - n * mean * mean) / (n - 1.0);
        // error = offset + Δ(ε + σn) with ε = round(y) − y uniform on ±1/2 and independent of
        // n (the angles are random, so the fraction of y is uniform whatever n): mean `offset`,
        // variance Δ²(1/12 + σ²) exactly.
        let expected = resolution * resolution * (1.0 / 12.0 + encoder.noise_counts * encoder.noise_counts);
        assert!(relative(expected.sqrt(), encoder.angle_std()) < 1e-12);
        // Mean: within 4.5 standard errors (two-sided false alarm 7·10⁻⁶).
        assert!((mean - offset).abs() <= 4.5 * (expected / n).sqrt(), "{}: mean {mean} vs {offset}", profile.name);
        // Variance: (n − 1)s²/σ² is χ²(n − 1) for Gaussian errors; this error's excess kurtosis is
        // negative (a uniform part), so the spread of s² is smaller and the Gaussian interval is
        // conservative. The 99.99 % interval (z = 3.89) by Wilson–Hilferty.
        let nu = n - 1.0;
        let (low, high) = (chi_square_quantile(nu, -3.89) / nu, chi_square_quantile(nu, 3.89) / nu);
        let ratio = variance / expected;
        eprintln!(
            "{} offset {offset}: mean error {mean:.3e} rad, variance ratio {ratio:.4} (interval {low:.4}–{high:.4})",
            profile.name
        );
        assert!((low..=high).contains(&ratio), "{}: variance ratio {ratio}", profile.name);
    }
}

#[test]
fn sensor_delay_returns_the_reading_of_delay_samples_ago() {
    for delay in [0usize, 1, 2, 5, MAX_DELAY_SAMPLES] {
        // Exact angles with an offset and an exact rate sensor: each reading is a known function
        // of its state, so the delayed one can be named.
        let profile = SensorProfile::<2> {
            name: "test".into(),
            encoders: [EncoderSpec { counts_per_rev: None, noise_counts: 0.0, offset: 0.003 }; 2],
            delay_samples: delay,
            rate_noise: Some(JointVector::<2>::zeros()),
        };
        let mut sensors = Sensors::new(profile, 1).unwrap();
        let state_at = |k: i64| JointState {
            q: JointVector::<2>::new(0.01 * k as f64, -0.02 * k as f64),
            qd: JointVector::<2>::new(1.0 + k as f64, 2.0),
        };
        let initial = state_at(-1000);
        let due = sensors.reset(&initial);
        assert_eq!(due.q, initial.q + JointVector::<2>::repeat(0.003));
        for k in 0..(delay as i64 + 20) {
            let reading = sensors.measure(&state_at(k));
            // Before `delay` samples have passed, the line still holds readings of the start.
            let source = if k < delay as i64 { initial } else { state_at(k - delay as i64) };
            assert_eq!(reading.q, source.q + JointVector::<2>::repeat(0.003), "delay {delay}, sample {k}");
            assert_eq!(reading.qd, Some(source.qd), "delay {delay}, sample {k}");
        }
    }
}

#[test]
fn sensors_are_reproducible_by_seed_and_the_ideal_profile_is_exact() {
    let states: Vec<JointState<4>> = (0..100)
        .map(|k| JointState {
            q: JointVector::<4>::from_fn(|j, _| 0.01 * k as f64 + j as f64),
            qd: JointVector::<4>::repeat(0.1),
        })
        .collect();
    let readings = |seed: u64| {
        let mut sensors = Sensors::new(SensorProfile::<4>::hobby(), seed).unwrap();
        sensors.reset(&states[0]);
        states.iter().map(|s| sensors.measure(s)).collect::<Vec<_>>()
    };
    assert_eq!(readings(7), readings(7));
    let (a, b) = (readings(7), readings(8));
    let differing = a.iter().zip(&b).filter(|(x, y)| x != y).count();
    // σ = 0.5 count changes the rounded count in about 6 of 10 readings per joint.
    assert!(differing > 50, "only {differing} of 100 readings differ between seeds");

    let mut ideal = Sensors::<4>::ideal();
    ideal.reset(&states[0]);
    for state in &states {
        let reading = ideal.measure(state);
        assert_eq!(reading, Measurement { q: state.q, qd: Some(state.qd) });
    }
}

#[test]
fn sensor_profile_validation_names_the_field() {
    let field_of = |profile: SensorProfile<2>| match profile.validate() {
        Err(SenseError::InvalidField { field, .. }) => field,
        Ok(()) => String::from("(accepted)"),
    };
    let with_encoder = |change: &dyn Fn(&mut EncoderSpec)| {
        let mut profile = SensorProfile::<2>::hobby();
        change(&mut profile.encoders[1]);
        profile
    };
    assert_eq!(field_of(SensorProfile::hobby()), "(accepted)");
    assert_eq!(field_of(with_encoder(&|e| e.noise_counts = -0.1)), "sensors.hobby joint 2 noise_counts");
    assert_eq!(field_of(with_encoder(&|e| e.noise_counts = f64::NAN)), "sensors.hobby joint 2 noise_counts");
    assert_eq!(field_of(with_encoder(&|e| e.counts_per_rev = Some(0.0))), "sensors.hobby joint 2 counts_per_rev");
    assert_eq!(field_of(with_encoder(&|e| e.counts_per_rev = Some(f64::NAN))), "sensors.hobby joint 2 counts_per_rev");
    assert_eq!(field_of(with_encoder(&|e| e.offset = 7.0)), "sensors.hobby joint 2 offset");
    assert_eq!(field_of(with_encoder(&|e| e.offset = f64::NAN)), "sensors.hobby joint 2 offset");
    let mut delayed = SensorProfile::<2>::hobby();
    delayed.delay_samples = MAX_DELAY_SAMPLES + 1;
    assert_eq!(field_of(delayed), "sensors.hobby delay_samples");
    let mut rate = SensorProfile::<2>::hobby();
    rate.rate_noise = Some(JointVector::<2>::new(0.1, -1.0));
    assert_eq!(field_of(rate), "sensors.hobby joint 2 rate_noise");
}

#[test]
fn kalman_settings_validation_names_the_field() {
    let field_of = |result: Result<JointKalman<2>, SenseError>| match result {
        Err(SenseError::InvalidField { field, .. }) => field,
        Ok(_) => String::from("(accepted)"),
    };
    let std = JointVector::<2>::repeat(1e-3);
    let good = settings(1.0, Some(0.01));
    assert_eq!(field_of(JointKalman::new(1e-3, std, None, 1, good)), "(accepted)");
    assert_eq!(field_of(JointKalman::new(0.0, std, None, 1, good)), "kalman period");
    assert_eq!(field_of(JointKalman::new(f64::NAN, std, None, 1, good)), "kalman period");
    assert_eq!(
        field_of(JointKalman::new(1e-3, JointVector::<2>::new(1e-3, 0.0), None, 1, good)),
        "kalman angle_std joint 2"
    );
    assert_eq!(
        field_of(JointKalman::new(1e-3, std, Some(JointVector::<2>::new(-1.0, 0.1)), 1, good)),
        "kalman rate_std joint 1"
    );
    assert_eq!(field_of(JointKalman::new(1e-3, std, None, MAX_DELAY_SAMPLES + 1, good)), "kalman delay_samples");
    assert_eq!(field_of(JointKalman::new(1e-3, std, None, 1, settings(-1.0, None))), "kalman acceleration_noise");
    assert_eq!(
        field_of(JointKalman::new(1e-3, std, None, 1, settings(f64::INFINITY, None))),
        "kalman acceleration_noise"
    );
    assert_eq!(
        field_of(JointKalman::new(1e-3, std, None, 1, settings(1.0, Some(f64::NAN)))),
        "kalman disturbance_noise"
    );
    // An initial covariance must be symmetric and positive semi-definite.
    let mut filter = JointKalman::<2>::new(1e-3, std, None, 1, good).unwrap();
    let start = JointState::at_rest(JointVector::<2>::zeros());
    assert!(filter.reset_with_covariance(&start, &Matrix3::from_diagonal(&Vector3::new(1.0, -1.0, 0.0))).is_err());
    assert!(filter.reset_with_covariance(&start, &Matrix3::new(1.0, 0.5, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0)).is_err());
    assert!(filter.reset_with_covariance(&start, &Matrix3::identity()).is_ok());
}

/// On a ramp `q = v t` the finite differences are `v` exactly, so the low-pass follows
/// `v̂_k = v (1 − e^{−kT/τ})` from 0 and converges to `v`.
#[test]
fn lowpass_velocity_converges_to_the_ramp_rate() {
    let (t, v) = (1e-3, 0.7);
    let mut filter = LowPassVelocity::<1>::new(t, LowPassVelocity::<1>::DEFAULT_TIME_CONSTANT).unwrap();
    filter.reset(&JointState::at_rest(JointVector::<1>::zeros()));
    let tau = filter.time_constant();
    for k in 1..=300 {
        let q = v * k as f64 * t;
        let estimate = filter.update(&angles(JointVector::<1>::new(q)));
        let expected = v * (1.0 - (-(k as f64) * t / tau).exp());
        // Differences of q = v k T carry rounding of ~10⁻¹⁶ q / T: 10⁻¹⁰ rad/s is ample.
        assert!((estimate.qd[0] - expected).abs() <= 1e-10, "k {k}: {} vs {expected}", estimate.qd[0]);
        assert_eq!(estimate.q[0], q);
    }
    // After 30 τ: e^{−30} ≈ 10⁻¹³ of v left.
    let last = filter.update(&angles(JointVector::<1>::new(v * 301.0 * t)));
    assert!((last.qd[0] - v).abs() <= 1e-9);
}

// ---------------------------------------------------------------------------------------------
// 7. The Kalman filter beats the baseline
// ---------------------------------------------------------------------------------------------

/// A smooth point-to-point motion of the kind the planner makes, read by the hobby profile
/// (Δ = 2π/4096, σ = 0.5 count, 1 sample late). The commanded acceleration is the reference's,
/// held over each sample as computed torque applies it; the plant's actual acceleration differs
/// from it by a smooth unknown 0.3 rad/s² (model error). The filter uses σ_a = 1 rad/s².
#[test]
fn kalman_rate_estimate_beats_the_lowpass_baseline_on_hobby_encoders() {
    let t = 1e-3;
    let profile = SensorProfile::<1>::hobby();
    assert!(relative(profile.encoders[0].resolution(), TAU / 4096.0) < 1e-15);
    let duration = 4.0;
    let steps = (duration / t) as usize;
    // Reference: q = A (1 − cos(2π t / D)) / 2 over D = 4 s, 1.2 rad peak to peak.
    let amplitude = 1.2;
    let omega = TAU / duration;
    let reference_acceleration = |time: f64| amplitude / 2.0 * omega * omega * (omega * time).cos();
    let mismatch = |time: f64| 0.3 * (TAU * 0.7 * time).sin();
    let mut sensors = Sensors::new(profile.clone(), 31).unwrap();
    let mut state = JointState::at_rest(JointVector::<1>::new(0.2));
    let due = sensors.reset(&state);
    let start = JointState { q: due.q, qd: state.qd };
    let mut kalman = JointKalman::<1>::new(t, profile.angle_std(), None, 1, settings(1.0, None)).unwrap();
    kalman.reset(&start);
    let mut lowpass = LowPassVelocity::<1>::new(t, LowPassVelocity::<1>::DEFAULT_TIME_CONSTANT).unwrap();
    lowpass.reset(&start);
    let (mut kalman_square, mut lowpass_square, mut kalman_angle, mut reading_angle) = (0.0, 0.0, 0.0, 0.0);
    let mut applied = JointVector::<1>::zeros();
    let skip = 100; // the first 0.1 s: the low-pass's start transient (10 τ)
    for k in 0..steps {
        let measurement = sensors.measure(&state);
        let from_kalman = kalman.update(&measurement, &applied);
        let from_lowpass = lowpass.update(&measurement);
        if k >= skip {
            kalman_square += (from_kalman.qd[0] - state.qd[0]).powi(2);
            lowpass_square += (from_lowpass.qd[0] - state.qd[0]).powi(2);
            kalman_angle += (from_kalman.q[0] - state.q[0]).powi(2);
            reading_angle += (measurement.q[0] - state.q[0]).powi(2);
        }
        let time = k as f64 * t;
        let u = reference_acceleration(time);
        let acceleration = u + mismatch(time);
        state.q[0] += state.qd[0] * t + 0.5 * acceleration * t * t;
        state.qd[0] += acceleration * t;
        applied = JointVector::<1>::new(u);
    }
    let samples = (steps - skip) as f64;
    let (kalman_rms, lowpass_rms) = ((kalman_square / samples).sqrt(), (lowpass_square / samples).sqrt());
    eprintln!(
        "hobby encoders, 1 kHz: RMS rate error Kalman {kalman_rms:.4} rad/s, low-pass (τ = 10 ms) {lowpass_rms:.4} rad/s; RMS angle error Kalman {:.3e} rad, raw reading {:.3e} rad",
        (kalman_angle / samples).sqrt(),
        (reading_angle / samples).sqrt()
    );
    assert!(kalman_rms < lowpass_rms, "Kalman {kalman_rms} vs low-pass {lowpass_rms}");
}

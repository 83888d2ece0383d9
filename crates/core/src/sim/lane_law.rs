//! The computed-torque laws of a batch's runs ([`super::batch`]) in lanes: for a batch whose
//! every run has a plain computed-torque controller
//! ([`ComputedTorque`](computed_torque::ComputedTorque), PD or PID, without friction
//! compensation) that sees the exact state at every step, with no motor lag, the
//! controllers' torques and the runs' error metrics are computed for all lanes at once, by the
//! formulas the scalar controller and closed loop use ([`computed_torque::outer_loop`],
//! [`computed_torque::computed_torque`], [`Tracking::record`]), the same IEEE operations in
//! the same order per lane. Each lane's results are therefore the scalar run's, bit for bit.
//!
//! Where every run's controller sees the estimate of a Kalman filter instead (and the filters
//! share a delay and a velocity sensor or none), the filters run in lanes too
//! ([`KalmanLanes`]), with the estimates' error statistics, and where the runs' sensors draw
//! alike, the sensors too ([`SensorLanes`]: each lane's noise from its run's own generator,
//! the generators side by side).

// The law indexes several arrays by joint and lane, as its equations do.
#![allow(clippy::needless_range_loop)]

use super::closed_loop::{Run, Tracking, clipped_acceleration};
use super::structured::{Start, State};
use crate::arm::dynamics::DynamicsTerms;
use crate::arm::model::JointVector;
use crate::control::computed_torque::{self, AntiWindup};
use crate::control::{Controller, Reference};
use crate::lanes::{Lanes, Real, array4};
use crate::sense::kalman::KalmanLanes;
use crate::sense::sensors::{ReadingLanes, SensorLanes};

/// The Kalman filters of a batch whose controllers see estimates, with what each scalar run
/// keeps of its feedback.
#[derive(Debug, Clone)]
pub(crate) struct FeedbackLanes<const L: usize> {
    kalman: KalmanLanes<L>,
    /// The runs' sensors, where they draw alike (`None`: each run's read lane by lane).
    sensors: Option<SensorLanes<L>>,
    /// The acceleration each controller commanded over the sample just ended, as its model
    /// predicts it (the filters' input), rad/s².
    applied: [Lanes<L>; 4],
    /// Sums of the squared angle (rad²) and rate (rad²/s²) errors of the estimates.
    squared_errors: ([Lanes<L>; 4], [Lanes<L>; 4]),
}

/// The laws' gains and integrals, lane by lane, and the runs' metrics in lanes.
#[derive(Debug, Clone)]
pub(crate) struct LaneLaw<const L: usize> {
    /// `[kp, kd, ki]` per joint.
    gains: [[Lanes<L>; 4]; 3],
    /// `∫e`, rad·s.
    integral: [Lanes<L>; 4],
    /// The latest outer-loop acceleration `v`, rad/s².
    commanded: [Lanes<L>; 4],
    /// `integral` and `commanded` before the latest sample, for a lane that fails before
    /// its controller would have run ([`LaneLaw::hand_back_unsampled`]).
    previous: ([Lanes<L>; 4], [Lanes<L>; 4]),
    /// Per lane: its anti-windup where its law integrates (some `ki > 0`), else `None`.
    integrates: [Option<AntiWindup>; L],
    /// The controllers' models' torque limits (N·m), for the clamping anti-windup.
    model_limits: [Lanes<L>; 4],
    /// The runs' metrics.
    pub tracking: Tracking<Lanes<L>, 4>,
    /// The runs' Kalman filters, where their controllers see estimates (`None`: the exact state).
    feedback: Option<FeedbackLanes<L>>,
}

impl<const L: usize> LaneLaw<L> {
    /// The laws of `runs` (lane `i` is `runs[i]`, `None` for a lane that never starts), if
    /// every run that starts can run in lanes: [`Run::runs_in_lanes`] (all with the exact
    /// state, or all with Kalman filters that [`KalmanLanes::of`] takes), a
    /// [`ComputedTorque`](computed_torque::ComputedTorque)
    /// controller whose model is of the yaw–pitch family and has no friction, and the same
    /// reference, step count, first tracked step and control period as the others.
    pub fn of<C, R>(runs: &mut [Option<Run<'_, 4, C, R>>]) -> Option<Self>
    where
        C: Controller<4> + ?Sized,
        R: super::ReferenceSource<4> + ?Sized,
    {
        let first = runs.iter().flatten().next()?;
        let (reference, steps, tracked_from, period, exact) = (
            first.reference() as *const R,
            first.steps,
            first.first_tracked_step(),
            first.config.control_period,
            first.is_exact(),
        );
        let mut gains = [[[0.0; L]; 4]; 3];
        let mut integral = [[0.0; L]; 4];
        let mut model_limits = [[0.0; L]; 4];
        let mut integrates = [None; L];
        for (i, run) in runs.iter_mut().enumerate() {
            let Some(run) = run else { continue };
            let same = std::ptr::eq(run.reference(), reference)
                && run.steps == steps
                && run.first_tracked_step() == tracked_from
                && run.config.control_period.to_bits() == period.to_bits()
                && run.runs_in_lanes()
                && run.is_exact() == exact;
            let law = run.as_computed_torque()?;
            if !same || law.model().has_friction() || law.model().yaw_pitch().is_none() {
                return None;
            }
            let rows = law.gain_rows();
            let limits = law.model().torque_limits();
            for j in 0..4 {
                for (k, row) in rows.iter().enumerate() {
                    gains[k][j][i] = row[j];
                }
                integral[j][i] = law.integral()[j];
                model_limits[j][i] = limits[j];
            }
            integrates[i] = law.gains().has_integral().then_some(law.anti_windup());
        }
        let feedback = if exact {
            None
        } else {
            let run = |i: usize| runs.get(i).and_then(Option::as_ref);
            let filters = std::array::from_fn(|i| run(i).and_then(Run::kalman));
            let sensors = SensorLanes::of(std::array::from_fn(|i| run(i).map(Run::sensors)));
            let zero = [Lanes::splat(0.0); 4];
            Some(FeedbackLanes {
                kalman: KalmanLanes::of(filters)?,
                sensors,
                applied: zero,
                squared_errors: (zero, zero),
            })
        };
        let lanes = |v: [[f64; L]; 4]| v.map(Lanes);
        Some(Self {
            gains: gains.map(lanes),
            integral: lanes(integral),
            commanded: [Lanes::splat(0.0); 4],
            previous: (lanes(integral), [Lanes::splat(0.0); 4]),
            integrates,
            model_limits: lanes(model_limits),
            tracking: Tracking::new(),
            feedback,
        })
    }

    /// Whether the controllers see the estimates of Kalman filters run in lanes
    /// ([`LaneLaw::estimate`]) rather than the exact state.
    pub fn estimates(&self) -> bool {
        self.feedback.is_some()
    }

    /// Whether the runs' sensors read in lanes too ([`LaneLaw::read_and_estimate`]).
    pub fn reads(&self) -> bool {
        self.feedback.as_ref().is_some_and(|feedback| feedback.sensors.is_some())
    }

    /// Where the sensors read in lanes ([`LaneLaw::reads`]): every lane's reading of the
    /// plant's `state` now, and its estimate from the reading due ([`LaneLaw::estimate`]).
    /// `None` where they do not.
    #[inline(always)]
    pub fn read_and_estimate(&mut self, state: &State<Lanes<L>>) -> Option<State<Lanes<L>>> {
        let (q, qd): ReadingLanes<L> = self.feedback.as_mut()?.sensors.as_mut()?.measure((&state.q, &state.qd));
        self.estimate((&q, &qd), state)
    }

    /// Every lane's estimate of the state now from the readings `(q, qd)` due at this sample
    /// (rad, rad/s; a missing rate NaN), as its run's feedback gives it
    /// ([`crate::sense::Feedback::observe`]), and the estimates' errors against the plant's
    /// `state` added up as the run adds them. `None` where the controllers see the exact
    /// state.
    #[inline(always)]
    pub fn estimate(
        &mut self,
        (q, qd): (&[Lanes<L>; 4], &[Lanes<L>; 4]),
        state: &State<Lanes<L>>,
    ) -> Option<State<Lanes<L>>> {
        let feedback = self.feedback.as_mut()?;
        let (estimate_q, estimate_qd) = feedback.kalman.update(q, qd, &feedback.applied);
        let (angle, rate) = &mut feedback.squared_errors;
        for j in 0..4 {
            let (error_q, error_qd) = (estimate_q[j] - state.q[j], estimate_qd[j] - state.qd[j]);
            angle[j] += error_q * error_q;
            rate[j] += error_qd * error_qd;
        }
        Some(State { q: estimate_q, qd: estimate_qd })
    }

    /// After lane `i`'s controller sample (its command, after clipping, `command`, N·m): the
    /// acceleration its filter takes as input over the coming sample, the law's `v` or, where
    /// the command was `clipped`, what the clipped command gives with the controller's
    /// `terms` at the state it saw ([`clipped_acceleration`]), as the scalar run computes it.
    pub fn sampled(
        &mut self,
        i: usize,
        clipped: bool,
        command: &JointVector<4>,
        terms: impl FnOnce() -> DynamicsTerms<4>,
    ) {
        let Some(feedback) = self.feedback.as_mut() else { return };
        if clipped {
            let commanded = JointVector::from_fn(|j, _| self.commanded[j].0[i]);
            let applied = clipped_acceleration(commanded, command, &terms());
            for j in 0..4 {
                feedback.applied[j].0[i] = applied[j];
            }
        } else {
            // Lane to lane, without a vector between (whose copy waited on its stores).
            for j in 0..4 {
                feedback.applied[j].0[i] = self.commanded[j].0[i];
            }
        }
    }

    /// [`LaneLaw::sampled`] for every lane at once, with their clipped commands `command`
    /// (N·m): the lanes of `clipped` (bit `i` for lane `i`) take what their clipped command
    /// gives with their controllers' `terms`, the others the law's `v`.
    pub fn sampled_lanes(&mut self, clipped: u64, command: &[Lanes<L>; 4], terms: impl Fn(usize) -> DynamicsTerms<4>) {
        let Some(feedback) = self.feedback.as_mut() else { return };
        feedback.applied = self.commanded;
        for i in (0..L).filter(|i| clipped & (1 << i) != 0) {
            self.sampled(i, true, &JointVector::from_fn(|j, _| command[j].0[i]), || terms(i));
        }
    }

    /// Lane `i`'s sums of squared estimate errors ([`Run::summary_with`]), where the batch ran
    /// the estimators.
    pub fn estimate_errors(&self, i: usize) -> Option<(JointVector<4>, JointVector<4>)> {
        let lane = |v: &[Lanes<L>; 4]| JointVector::from_fn(|j, _| v[j].0[i]);
        self.feedback.as_ref().map(|feedback| (lane(&feedback.squared_errors.0), lane(&feedback.squared_errors.1)))
    }

    /// Hands lane `i`'s filter state back to its run's Kalman filter, and its sensors' to its
    /// sensors where they read in lanes (with the batch's estimators): as the scalar run leaves
    /// them at the latest sample, or, called before the sample's reading and update, before it.
    pub fn hand_back_feedback<C, R>(&self, i: usize, run: &mut Run<'_, 4, C, R>)
    where
        C: Controller<4> + ?Sized,
        R: super::ReferenceSource<4> + ?Sized,
    {
        let Some(feedback) = self.feedback.as_ref() else { return };
        if let Some(filter) = run.kalman_mut() {
            feedback.kalman.hand_back(i, filter);
        }
        if let Some(sensors) = feedback.sensors.as_ref() {
            sensors.hand_back(i, run.sensors_mut());
        }
    }

    /// Every lane's torque command before clipping (N·m), as its
    /// [`Controller::command_with_terms`](crate::control::Controller::command_with_terms)
    /// computes it at `state` (rad, rad/s) with the
    /// terms of `plant` (the plant's) or, for the lanes of `own`, of `own_terms` (the
    /// controllers' models'), following `reference` with samples of `period` s.
    #[inline(always)]
    pub fn torque(
        &mut self,
        (q, qd): (&[Lanes<L>; 4], &[Lanes<L>; 4]),
        plant: &Start<Lanes<L>>,
        own_terms: &Start<Lanes<L>>,
        own: u64,
        reference: &Reference<4>,
        period: f64,
    ) -> [Lanes<L>; 4] {
        let splat = |v: &crate::arm::model::JointVector<4>| -> [Lanes<L>; 4] { array4(|j| Lanes::splat(v[j])) };
        let (q_d, qd_d, qdd_d) = (splat(&reference.q), splat(&reference.qd), splat(&reference.qdd));
        let error = array4(|j| q_d[j] - q[j]);
        let error_rate = array4(|j| qd_d[j] - qd[j]);
        // The terms each lane's controller takes.
        let mixed;
        let (mass_matrix, bias) = if own == 0 {
            (&plant.configuration.mass_matrix, &plant.bias)
        } else if own.count_ones() as usize == L {
            (&own_terms.configuration.mass_matrix, &own_terms.bias)
        } else {
            let mut mass_matrix = plant.configuration.mass_matrix;
            let mut bias = plant.bias;
            for i in (0..L).filter(|i| own & (1 << i) != 0) {
                for r in 0..4 {
                    for c in 0..4 {
                        mass_matrix[r][c].0[i] = own_terms.configuration.mass_matrix[r][c].0[i];
                    }
                    bias[r].0[i] = own_terms.bias[r].0[i];
                }
            }
            mixed = (mass_matrix, bias);
            (&mixed.0, &mixed.1)
        };
        let before = self.integral;
        self.previous = (self.integral, self.commanded);
        for (i, integrates) in self.integrates.iter().enumerate() {
            match integrates {
                None => {}
                Some(AntiWindup::None) => {
                    for j in 0..4 {
                        self.integral[j].0[i] += error[j].0[i] * period;
                    }
                }
                Some(AntiWindup::Clamp { error_band }) => {
                    for j in 0..4 {
                        self.integral[j].0[i] += error[j].0[i].clamp(-error_band, *error_band) * period;
                    }
                }
            }
        }
        let mut outer = computed_torque::outer_loop(&qdd_d, &self.gains, &error, &error_rate, &self.integral);
        let mut torque = computed_torque::computed_torque(mass_matrix, &outer, bias);
        // The clamping anti-windup: a joint whose command lies beyond its limit with its error
        // of the same sign keeps its previous integral, and the command is computed again. A
        // lane that keeps none gets the same bits again from the same inputs.
        let mut held = false;
        for (i, integrates) in self.integrates.iter().enumerate() {
            if let Some(AntiWindup::Clamp { .. }) = integrates {
                for j in 0..4 {
                    let (tau, limit, e) = (torque[j].0[i], self.model_limits[j].0[i], error[j].0[i]);
                    let deeper = (tau > limit && e > 0.0) || (tau < -limit && e < 0.0);
                    if deeper && self.gains[2][j].0[i] > 0.0 {
                        self.integral[j].0[i] = before[j].0[i];
                        held = true;
                    }
                }
            }
        }
        if held {
            outer = computed_torque::outer_loop(&qdd_d, &self.gains, &error, &error_rate, &self.integral);
            torque = computed_torque::computed_torque(mass_matrix, &outer, bias);
        }
        self.commanded = outer;
        torque
    }

    /// Hands lane `i`'s integral and latest `v` back to its run's controller, and its filter's
    /// and sensors' state to them ([`LaneLaw::hand_back_feedback`]), as the scalar run leaves
    /// them: at the end, or where it fails after its latest sample.
    pub fn hand_back<C, R>(&self, i: usize, run: &mut Run<'_, 4, C, R>)
    where
        C: Controller<4> + ?Sized,
        R: super::ReferenceSource<4> + ?Sized,
    {
        self.hand_back_feedback(i, run);
        if let Some(law) = run.as_computed_torque() {
            law.set_law_state(self.integral.map(|v| v.0[i]), self.commanded.map(|v| v.0[i]));
        }
    }

    /// [`LaneLaw::hand_back`] for a lane that fails at the latest sample before its controller
    /// would run (its plant's `M` not positive definite): the controller's state from before
    /// that sample (its filter's was handed back before the sample's update).
    pub fn hand_back_unsampled<C, R>(&self, i: usize, run: &mut Run<'_, 4, C, R>)
    where
        C: Controller<4> + ?Sized,
        R: super::ReferenceSource<4> + ?Sized,
    {
        if let Some(law) = run.as_computed_torque() {
            law.set_law_state(self.previous.0.map(|v| v.0[i]), self.previous.1.map(|v| v.0[i]));
        }
    }
}

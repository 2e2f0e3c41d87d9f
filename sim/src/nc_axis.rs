//! The NC feed-axis stage of `003_…txt`: a linear full-slot milling operation along x whose wall is
//! displaced by the tool deflection orthogonal to the feed, compensated by superimposing a correction on
//! the y axis' position reference in the NC's 2 ms position-control cycle.
//!
//! What the stage is made of (each piece a stated assumption where 003 gives nothing):
//!
//! * **The NC program and interpolator** ([`NcProgram`], [`NcInterpolator`]): the tool starts in air
//!   before the blank, cuts a full slot (ae = D) from the blank's start to its end at the programmed feed,
//!   changes feed where the program says (003: 500 → 1000 mm/min "abruptly in the NC code" half-way) and
//!   leaves the blank at its end (the exit). The NC turns a feed change into a jerk-limited S-curve of the
//!   path velocity (`path_accel_mm_s2`, `path_jerk_mm_s3`; 003 gives neither: 2 m/s² and 50 m/s³ by
//!   default, typical commissioning values of a machining centre's path dynamics). The reference
//!   acceleration `a_cmd` is non-zero exactly while the S-curve runs — the trigger of 003's proactive
//!   offset curve (§2.3).
//! * **The feed axes** ([`AxisDynamics`], the truth's structure): a dead time followed by a P
//!   position loop around a velocity loop, `kv/(Tv s² + s + kv)`. A ramp's actual position lags its
//!   reference by [`AxisDynamics::equivalent_delay_s`] = 16 ms: 003's "delay time of the feed axis"
//!   (Fig. 3). Two splits are
//!   provided: [`AxisDynamics::speed_feedforward_003`] (12 + 4 ms, the 840D sl's standard speed
//!   feedforward, its set-points fine-interpolated over the cycle; the shipped scenarios' axes since
//!   the diagnosis of `docs/studies/published-nc.md`)
//!   and [`AxisDynamics::brecher_003`] (4 ms dead time — the set-point reaches the drive one cycle
//!   after the NC computes it and the drive's inner loops take about one more — and kv = 83.3 1/s
//!   around a 2 ms velocity loop: a P loop without feedforward, the scenarios' axes before). The
//!   controllers' model of it is identified, with another structure (dead time + first-order lag).
//! * **The cutting force** (`crate::kienzle`): Kienzle's law for C45 with edge forces on top, on 003's
//!   Ø16 mm 5-tooth end mill, evaluated at every stage step at the actual position and the actual feed per
//!   tooth (from the x axis' actual velocity).
//! * **Tool-tip deflection** ([`NcStiffness`], `003_…txt` eqs. 1–5 reconstructed: machine and tool in
//!   series, `1/k = 1/k_M + 1/k_T`): quasi-static, `δ = F_y/k` (003 compensates the static part only; the
//!   structure's modes are not modelled). The tool with its shrink chuck is a stepped cantilever loaded at
//!   the tip: the fluted length at 0.8·D equivalent diameter (Kops & Vo, CIRP Annals 39/1, 1990: the
//!   equivalent diameter of a fluted end mill ≈ 0.8 D), the rest of the overhang at D, carbide
//!   E = 586 GPa (`crate::stiffness::CARBIDE_E_GPA`). The machine's static stiffness k_M varies linearly
//!   along the groove by `machine_span_rel` (ΔkM/kM of eqs. 1–5 over the blank; 10 % assumed).
//! * **The force platform** ([`ForcePlatform`]): the orthogonal force read with a gain error, white noise
//!   and quantisation, sampled every stage step (10 kHz: a piezoelectric platform and its DAQ).
//! * **The wall**: the lower wall (y = −R) is generated where a tooth passes φ = π at the contour's
//!   height above the floor — at the pass instant, between the stage's steps (the axes interpolated
//!   over the step, the force at the pass angle); its position error is the tool tip's y there,
//!   `y_axis + δ` (+ = material
//!   left, the tool pushed away from the wall; 003's positive displacement). [`ContourDevice`] measures it
//!   afterwards.
//!
//! Sign conventions: forces on the tool, `F_y > 0` pushes it away from the lower wall; the y correction
//! moves the axis (µm); the wall error is `y_axis + δ`, so a perfect compensation is `y_axis = −δ`.

use std::collections::VecDeque;
use std::f64::consts::PI;

use serde::{Deserialize, Serialize};

use crate::error::{SimError, check_nonneg, check_positive, check_range};
use crate::kienzle::{CutState, KienzleMillingModel};
use crate::lti::{ContinuousLti, DiscreteLti};
use crate::sensors::{NoiseSource, quantize};
use crate::stiffness::{CARBIDE_E_GPA, series_n_per_um};

/// 003's position-control cycle (s): 500 Hz (`003_…txt` §2.3).
pub const NC_CYCLE_S: f64 = 0.002;
/// The stage step (s): 10 kHz, also the force platform's sampling rate.
pub const STAGE_DT_S: f64 = 1e-4;
/// 003's feed-axis delay (s), Fig. 3.
pub const AXIS_DELAY_003_S: f64 = 0.016;

/// A programmed feed change.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NcFeedChange {
    /// Position (mm) of the NC block with the new feed.
    pub x_mm: f64,
    /// New feed (mm/min).
    pub feed_mm_min: f64,
}

/// The NC program of the slot and the NC's path dynamics (what the NC and every controller know).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NcProgram {
    /// Spindle speed (rpm).
    pub speed_rpm: f64,
    /// Axial depth of cut (mm).
    pub ap_mm: f64,
    /// Radial depth of cut (mm; the tool diameter for a full slot).
    pub ae_mm: f64,
    /// Feed at the start (mm/min).
    pub feed_mm_min: f64,
    /// Feed changes along the cut.
    #[serde(default)]
    pub feed_changes: Vec<NcFeedChange>,
    /// Where the tool starts (mm): in air before the blank.
    pub start_mm: f64,
    /// Where the program ends (mm): past the blank.
    pub end_mm: f64,
    /// The blank's start along x (mm).
    pub blank_start_mm: f64,
    /// The blank's end along x (mm): the workpiece edge the cutter exits.
    pub blank_end_mm: f64,
    /// Position-control cycle (s).
    pub cycle_s: f64,
    /// Path acceleration limit of a feed change (mm/s²).
    pub path_accel_mm_s2: f64,
    /// Path jerk limit (mm/s³).
    pub path_jerk_mm_s3: f64,
}

impl NcProgram {
    /// 003's test cut (`003_…txt` §3, Fig. 5): full slot ae = 16 mm, ap = 8 mm, 1990 rpm, 500 mm/min
    /// stepped to 1000 mm/min at 90 mm, the exit at 185 mm; the tool starts 10 mm before the blank and
    /// ends 10 mm past it; 2 ms cycle, 2 m/s², 50 m/s³ (assumed, module doc).
    pub fn brecher_003() -> Self {
        Self {
            speed_rpm: 1990.0,
            ap_mm: 8.0,
            ae_mm: 16.0,
            feed_mm_min: 500.0,
            feed_changes: vec![NcFeedChange {
                x_mm: 90.0,
                feed_mm_min: 1000.0,
            }],
            start_mm: -10.0,
            end_mm: 195.0,
            blank_start_mm: 0.0,
            blank_end_mm: 185.0,
            cycle_s: NC_CYCLE_S,
            path_accel_mm_s2: 2000.0,
            path_jerk_mm_s3: 50_000.0,
        }
    }

    /// Validate against an axis whose largest feed is `max_feed_mm_min`.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming the field (`speed_rpm`, `feed_mm_min`,
    /// `feed_changes.x_mm`, `feed_changes.feed_mm_min` — also when above the axis' maximum —, `end_mm`,
    /// `blank_end_mm`, `cycle_s`, `path_accel_mm_s2`, `path_jerk_mm_s3`, …).
    pub fn validate(&self, max_feed_mm_min: f64) -> Result<(), SimError> {
        check_positive("speed_rpm", self.speed_rpm)?;
        check_positive("ap_mm", self.ap_mm)?;
        check_positive("ae_mm", self.ae_mm)?;
        check_positive("max_feed_mm_min", max_feed_mm_min)?;
        check_range(
            "feed_mm_min",
            self.feed_mm_min,
            1e-6,
            max_feed_mm_min,
            "0 < feed_mm_min <= the axis' max_feed_mm_min",
        )?;
        check_positive("cycle_s", self.cycle_s)?;
        check_positive("path_accel_mm_s2", self.path_accel_mm_s2)?;
        check_positive("path_jerk_mm_s3", self.path_jerk_mm_s3)?;
        if !(self.start_mm.is_finite() && self.start_mm < self.blank_start_mm) {
            return Err(SimError::InvalidParameter {
                name: "start_mm",
                value: self.start_mm,
                allowed: "finite, < blank_start_mm (the tool starts in air)",
            });
        }
        if !(self.blank_end_mm.is_finite() && self.blank_end_mm > self.blank_start_mm) {
            return Err(SimError::InvalidParameter {
                name: "blank_end_mm",
                value: self.blank_end_mm,
                allowed: "finite, > blank_start_mm",
            });
        }
        if !(self.end_mm.is_finite() && self.end_mm > self.blank_end_mm) {
            return Err(SimError::InvalidParameter {
                name: "end_mm",
                value: self.end_mm,
                allowed: "finite, > blank_end_mm",
            });
        }
        let mut last = self.start_mm;
        for c in &self.feed_changes {
            if !(c.x_mm.is_finite() && c.x_mm >= last && c.x_mm < self.end_mm) {
                return Err(SimError::InvalidParameter {
                    name: "feed_changes.x_mm",
                    value: c.x_mm,
                    allowed: "sorted, start_mm <= x_mm < end_mm",
                });
            }
            last = c.x_mm;
            check_range(
                "feed_changes.feed_mm_min",
                c.feed_mm_min,
                1e-6,
                max_feed_mm_min,
                "0 < feed_mm_min <= the axis' max_feed_mm_min",
            )?;
        }
        Ok(())
    }
}

/// One NC cycle of the interpolator's output.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NcReference {
    /// Reference position (mm).
    pub x_mm: f64,
    /// Reference path velocity (mm/s).
    pub v_mm_s: f64,
    /// Reference acceleration (mm/s²), non-zero while a feed change runs.
    pub a_mm_s2: f64,
}

/// The NC's set-point generator: the program turned into one reference per position cycle, computed once
/// (the NC's look-ahead; the controllers may read it ahead of time).
#[derive(Debug, Clone, PartialEq)]
pub struct NcInterpolator {
    refs: Vec<NcReference>,
    cycle_s: f64,
}

/// A jerk-limited velocity change from `v0` by `dv` (signed).
#[derive(Debug, Clone, Copy)]
struct SCurve {
    v0: f64,
    dv: f64,
    tj: f64,
    ta: f64,
    jerk: f64,
    a_peak: f64,
}

impl SCurve {
    fn new(v0: f64, v1: f64, amax: f64, jerk: f64) -> Self {
        let d = (v1 - v0).abs();
        let (tj, ta, a_peak) = if d <= amax * amax / jerk {
            let tj = (d / jerk).sqrt();
            (tj, 0.0, jerk * tj)
        } else {
            let tj = amax / jerk;
            (tj, d / amax - tj, amax)
        };
        Self {
            v0,
            dv: v1 - v0,
            tj,
            ta,
            jerk,
            a_peak,
        }
    }
    fn duration(&self) -> f64 {
        2.0 * self.tj + self.ta
    }
    /// (v, a) at τ after the start.
    fn at(&self, tau: f64) -> (f64, f64) {
        let s = self.dv.signum();
        let d = self.dv.abs();
        let t = self.duration();
        if tau <= 0.0 {
            (self.v0, 0.0)
        } else if tau < self.tj {
            (
                self.v0 + s * 0.5 * self.jerk * tau * tau,
                s * self.jerk * tau,
            )
        } else if tau < self.tj + self.ta {
            (
                self.v0 + s * (0.5 * self.a_peak * self.tj + self.a_peak * (tau - self.tj)),
                s * self.a_peak,
            )
        } else if tau < t {
            let r = t - tau;
            (
                self.v0 + s * (d - 0.5 * self.jerk * r * r),
                s * self.jerk * r,
            )
        } else {
            (self.v0 + self.dv, 0.0)
        }
    }
}

/// Sub-steps per cycle with which the interpolator integrates the path.
const INTERP_SUBSTEPS: usize = 20;

impl NcInterpolator {
    /// The references of `program`, one per position cycle, from the start until the reference reaches
    /// `end_mm` (then held there for `settle_cycles` more cycles).
    ///
    /// ```
    /// use millcomp_sim::nc_axis::{NcInterpolator, NcProgram};
    /// let p = NcProgram::brecher_003();
    /// let ip = NcInterpolator::new(&p, 50).unwrap();
    /// // 500 mm/min = 8.333 mm/s before the change, 16.67 mm/s after it
    /// let k = ip.cycle_at_x(50.0).unwrap();
    /// assert!((ip.reference(k).v_mm_s - 8.3333).abs() < 1e-3);
    /// let k = ip.cycle_at_x(120.0).unwrap();
    /// assert!((ip.reference(k).v_mm_s - 16.6667).abs() < 1e-3);
    /// // the S-curve: Δv = 8.33 mm/s at 50 m/s³ (below 2 m/s²) takes 2·√(Δv/J) = 25.8 ms
    /// let acc = (0..ip.len()).filter(|&k| ip.reference(k).a_mm_s2 != 0.0).count();
    /// assert!((acc as f64 * 0.002 - 0.0258).abs() <= 0.0021, "{acc}");
    /// ```
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] for a program that is not valid (see [`NcProgram::validate`], with
    /// an unlimited axis) or that would take more than 10⁷ cycles.
    pub fn new(program: &NcProgram, settle_cycles: usize) -> Result<Self, SimError> {
        program.validate(f64::MAX)?;
        let dt = program.cycle_s / INTERP_SUBSTEPS as f64;
        let mut refs = Vec::new();
        let mut x = program.start_mm;
        let mut v = program.feed_mm_min / 60.0;
        let mut a: f64;
        let mut next_change = 0usize;
        let mut curve: Option<(SCurve, f64)> = None; // (curve, τ)
        let mut t_in_cycle = 0usize;
        let mut v_cycle_start = v;
        let mut ran = false;
        refs.push(NcReference {
            x_mm: x,
            v_mm_s: v,
            a_mm_s2: 0.0,
        });
        loop {
            // start the next change when the reference reaches it (and no change is running)
            if curve.is_none()
                && let Some(c) = program.feed_changes.get(next_change)
                && x >= c.x_mm
            {
                next_change += 1;
                let v1 = c.feed_mm_min / 60.0;
                if (v1 - v).abs() > 1e-12 {
                    curve = Some((
                        SCurve::new(v, v1, program.path_accel_mm_s2, program.path_jerk_mm_s3),
                        0.0,
                    ));
                }
            }
            let v_old = v;
            a = 0.0;
            if let Some((c, tau)) = curve.as_mut() {
                ran = true;
                *tau += dt;
                let (vn, an) = c.at(*tau);
                v = vn;
                a = an;
                if *tau >= c.duration() {
                    v = c.v0 + c.dv;
                    a = 0.0;
                    curve = None;
                }
            }
            x += 0.5 * (v_old + v) * dt;
            t_in_cycle += 1;
            if t_in_cycle == INTERP_SUBSTEPS {
                t_in_cycle = 0;
                // a_cmd of this cycle: the mean acceleration of the cycle, non-zero when the S-curve ran
                let a_cycle = if ran {
                    let a_mean = (v - v_cycle_start) / program.cycle_s;
                    if a_mean == 0.0 {
                        a.max(f64::MIN_POSITIVE)
                    } else {
                        a_mean
                    }
                } else {
                    0.0
                };
                ran = curve.is_some();
                v_cycle_start = v;
                if x >= program.end_mm {
                    refs.push(NcReference {
                        x_mm: program.end_mm,
                        v_mm_s: 0.0,
                        a_mm_s2: 0.0,
                    });
                    break;
                }
                refs.push(NcReference {
                    x_mm: x,
                    v_mm_s: v,
                    a_mm_s2: a_cycle,
                });
                if refs.len() > 10_000_000 {
                    return Err(SimError::InvalidParameter {
                        name: "end_mm",
                        value: program.end_mm,
                        allowed: "a program of at most 10^7 position cycles",
                    });
                }
            }
        }
        let last = *refs.last().expect("at least the start");
        refs.extend(std::iter::repeat_n(last, settle_cycles));
        Ok(Self {
            refs,
            cycle_s: program.cycle_s,
        })
    }

    /// Number of cycles.
    pub fn len(&self) -> usize {
        self.refs.len()
    }

    /// Whether there are no cycles (never: the start is one).
    pub fn is_empty(&self) -> bool {
        self.refs.is_empty()
    }

    /// The reference of cycle `k` (the last one beyond the end).
    pub fn reference(&self, k: usize) -> NcReference {
        self.refs[k.min(self.refs.len() - 1)]
    }

    /// The first cycle whose reference is at or past `x_mm`.
    pub fn cycle_at_x(&self, x_mm: f64) -> Option<usize> {
        self.refs.iter().position(|r| r.x_mm >= x_mm)
    }

    /// Position-control cycle (s).
    pub fn cycle_s(&self) -> f64 {
        self.cycle_s
    }
}

/// The truth's feed-axis structure (module doc): dead time, then `kv/(Tv s² + s + kv)`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AxisDynamics {
    /// Dead time (s).
    pub dead_time_s: f64,
    /// Position-loop gain kv (1/s).
    pub kv_per_s: f64,
    /// Velocity-loop time constant Tv (s).
    pub velocity_loop_s: f64,
    /// Largest feed (mm/min) the axis moves at.
    #[serde(default = "default_max_feed")]
    pub max_feed_mm_min: f64,
    /// Fine interpolation: the set-point latched at each NC cycle start reaches the position loop
    /// interpolated linearly from the previous one over the cycle ([`FeedAxis::new`]'s
    /// `steps_per_cycle`), as a NC's fine interpolator hands the interpolator's cycle set-points to
    /// the position-control clock (SINUMERIK: MD33000 `$MA_FIPO_TYPE`; from memory, unchecked);
    /// off: held over the cycle. Against a held set-point it delays a ramp by half a cycle more.
    /// Without it a fast loop (a few ms) follows the held set-points' staircase within each cycle,
    /// and the feed pulsates at the cycle rate.
    #[serde(default)]
    pub fine_interpolation: bool,
}

fn default_max_feed() -> f64 {
    30_000.0
}

impl AxisDynamics {
    /// 003's 16 ms as a P position loop without feedforward (module doc; the scenarios' axes until
    /// `docs/studies/published-nc.md`): 4 ms dead time, kv = 83.3 1/s, Tv = 2 ms: 16 ms for a ramp;
    /// 30 m/min rapid (assumed).
    ///
    /// ```
    /// use millcomp_sim::nc_axis::AxisDynamics;
    /// assert!((AxisDynamics::brecher_003().equivalent_delay_s(0.002) - 0.016).abs() < 1e-12);
    /// ```
    pub fn brecher_003() -> Self {
        Self {
            dead_time_s: 0.004,
            kv_per_s: 1.0 / 0.012,
            velocity_loop_s: 0.002,
            max_feed_mm_min: default_max_feed(),
            fine_interpolation: false,
        }
    }

    /// 003's axis as a SINUMERIK 840D sl runs it by default (the candidate of
    /// `docs/studies/published-nc.md`; the shipped scenarios' axes): speed feedforward with dead-time
    /// balancing — MD32620 `$MA_FFW_MODE` = 3, "speed feedforward control with Tt balancing (standard
    /// setting for 840D sl / 840Di sl)", which reduces the following error "almost to zero"
    /// (SINUMERIK 840D sl Function Manual Extended Functions K3, 09/2009, 6FC5397-1BP20-0BA0, §5.5).
    /// The reference then reaches the tool through the set-point's dead time and the speed loop's
    /// equivalent time constant (MD32810 `$MA_EQUIV_SPEEDCTRL_TIME`), the position loop correcting
    /// only what the feedforward misses: 003's 16 ms "delay time" (Fig. 3) split as 12 ms before the
    /// loop and 4 ms for the loop (kv = 250 1/s around a 1 ms velocity loop, a critically damped pair
    /// of poles at 500 rad/s). The 12 ms are the set-points' fine interpolation over the 2 ms cycle
    /// (linear: against a held set-point half a cycle more, 1 ms) and 11 ms dead time. The 4 ms is an
    /// assumption of the size of a speed loop's equivalent time constant (a few ms; from memory,
    /// unchecked); 30 m/min rapid as in [`Self::brecher_003`].
    ///
    /// ```
    /// use millcomp_sim::nc_axis::AxisDynamics;
    /// let a = AxisDynamics::speed_feedforward_003();
    /// assert!(a.fine_interpolation);
    /// assert!((a.equivalent_delay_s(0.002) - 0.016).abs() < 1e-12);
    /// assert!((a.kv_per_s * a.velocity_loop_s - 0.25).abs() < 1e-12); // critically damped
    /// ```
    pub fn speed_feedforward_003() -> Self {
        Self {
            dead_time_s: 0.011,
            kv_per_s: 250.0,
            velocity_loop_s: 0.001,
            max_feed_mm_min: default_max_feed(),
            fine_interpolation: true,
        }
    }

    /// The lag of a ramp's actual position behind its reference (s) with set-points latched every
    /// `cycle_s`, counted from a held set-point: `T_d + 1/kv`, plus half a cycle with fine
    /// interpolation.
    pub fn equivalent_delay_s(&self, cycle_s: f64) -> f64 {
        let fipo = if self.fine_interpolation {
            0.5 * cycle_s
        } else {
            0.0
        };
        self.dead_time_s + 1.0 / self.kv_per_s + fipo
    }

    /// Validate.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `dead_time_s`, `kv_per_s`, `velocity_loop_s` or
    /// `max_feed_mm_min`.
    pub fn validate(&self) -> Result<(), SimError> {
        check_range(
            "dead_time_s",
            self.dead_time_s,
            0.0,
            1.0,
            "0 <= dead_time_s <= 1",
        )?;
        check_positive("kv_per_s", self.kv_per_s)?;
        check_positive("velocity_loop_s", self.velocity_loop_s)?;
        check_positive("max_feed_mm_min", self.max_feed_mm_min)?;
        Ok(())
    }
}

/// A feed axis stepped at the stage rate: the reference (fine-interpolated over the NC cycle when
/// [`AxisDynamics::fine_interpolation`]) delayed by the dead time, through the loop.
#[derive(Debug, Clone)]
pub struct FeedAxis {
    lti: DiscreteLti,
    state: nalgebra::DVector<f64>,
    delay: VecDeque<f64>,
    position: f64,
    /// Fine interpolation: stage steps per NC cycle (0: off), the step within the cycle, and the
    /// previous and the latched set-point.
    fipo_steps: usize,
    fipo_step: usize,
    fipo_from: f64,
    fipo_to: f64,
}

impl FeedAxis {
    /// The axis at sample time `dt_s`, at rest at `position`, its set-points latched every
    /// `steps_per_cycle` steps from the first (the NC cycle; used by the fine interpolation only).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] for invalid dynamics, `steps_per_cycle` = 0, the
    /// discretisation's errors.
    pub fn new(
        d: &AxisDynamics,
        dt_s: f64,
        position: f64,
        steps_per_cycle: usize,
    ) -> Result<Self, SimError> {
        d.validate()?;
        check_positive("dt_s", dt_s)?;
        if steps_per_cycle == 0 {
            return Err(SimError::InvalidParameter {
                name: "steps_per_cycle",
                value: 0.0,
                allowed: ">= 1",
            });
        }
        let lti = ContinuousLti::from_transfer_function(
            &[d.kv_per_s],
            &[d.velocity_loop_s, 1.0, d.kv_per_s],
        )?
        .discretize_zoh(dt_s)?;
        let n = (d.dead_time_s / dt_s).round() as usize;
        let mut state = lti.zero_state();
        if position != 0.0 {
            state = lti.steady_state(&nalgebra::DVector::from_element(1, position))?;
        }
        Ok(Self {
            lti,
            state,
            delay: std::iter::repeat_n(position, n).collect(),
            position,
            fipo_steps: if d.fine_interpolation {
                steps_per_cycle
            } else {
                0
            },
            fipo_step: 0,
            fipo_from: position,
            fipo_to: position,
        })
    }

    /// One step with reference `r` (with fine interpolation, read at each cycle's first step);
    /// returns the actual position.
    pub fn step(&mut self, r: f64) -> f64 {
        let r = if self.fipo_steps > 0 {
            if self.fipo_step == 0 {
                self.fipo_from = self.fipo_to;
                self.fipo_to = r;
            }
            self.fipo_step += 1;
            let w = self.fipo_step as f64 / self.fipo_steps as f64;
            if self.fipo_step == self.fipo_steps {
                self.fipo_step = 0;
            }
            self.fipo_from + w * (self.fipo_to - self.fipo_from)
        } else {
            r
        };
        self.delay.push_back(r);
        let u = self.delay.pop_front().unwrap_or(r);
        self.position = self.lti.step_siso(&mut self.state, u);
        self.position
    }

    /// Actual position (after the last step).
    pub fn position(&self) -> f64 {
        self.position
    }
}

/// A reference held over each cycle of `cycle_s` through a dead time `dead_time_s` and a first-order lag
/// `lag_s` with unit gain, sampled at the cycle starts: `p[i+1] = a p[i] + b1 r[i−n] + b2 r[i−n−1]` with
/// `T_d = n T + θ`, `a = e^{−T/τ}`, `b1 = 1 − e^{−(T−θ)/τ}`, `b2 = e^{−(T−θ)/τ} − a` — exact for a dead
/// time that is not a whole number of cycles. Returns `(n, a, b1, b2)`. The structure the controllers
/// identify for a feed axis (`identify feed-axis`), not the truth's [`AxisDynamics`].
pub fn dead_time_lag_coefficients(
    cycle_s: f64,
    dead_time_s: f64,
    lag_s: f64,
) -> (usize, f64, f64, f64) {
    let n = (dead_time_s / cycle_s).floor().max(0.0);
    let theta = dead_time_s - n * cycle_s;
    let a = (-cycle_s / lag_s).exp();
    let e = (-(cycle_s - theta) / lag_s).exp();
    (n as usize, a, 1.0 - e, e - a)
}

/// The response of [`dead_time_lag_coefficients`]' model to `reference` (one value per cycle, held) from
/// `p0`, at the start of each cycle; the reference before the first cycle is its first value.
///
/// ```
/// use millcomp_sim::nc_axis::dead_time_lag_response;
/// // a 100 µm step sent at 2 ms through 4 ms dead time + 12 ms lag: nothing until 6 ms, then
/// // 100 (1 − e^{−(t − 6 ms)/τ})
/// let r: Vec<f64> = (0..20).map(|i| if i == 0 { 0.0 } else { 100.0 }).collect();
/// let p = dead_time_lag_response(&r, 0.0, 0.002, 0.004, 0.012);
/// assert_eq!((p[0], p[1], p[2], p[3]), (0.0, 0.0, 0.0, 0.0));
/// assert!((p[8] - 100.0 * (1.0 - (-0.010f64 / 0.012).exp())).abs() < 1e-9);
/// ```
pub fn dead_time_lag_response(
    reference: &[f64],
    p0: f64,
    cycle_s: f64,
    dead_time_s: f64,
    lag_s: f64,
) -> Vec<f64> {
    let (n, a, b1, b2) = dead_time_lag_coefficients(cycle_s, dead_time_s, lag_s);
    let n = n as isize;
    let r0 = reference.first().copied().unwrap_or(0.0);
    let at = |i: isize| if i < 0 { r0 } else { reference[i as usize] };
    let mut p = Vec::with_capacity(reference.len());
    let mut x = p0;
    for i in 0..reference.len() as isize {
        p.push(x);
        x = a * x + b1 * at(i - n) + b2 * at(i - n - 1);
    }
    p
}

/// The tool as a stepped cantilever from the chuck (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolOverhang {
    /// Tool diameter (mm).
    pub diameter_mm: f64,
    /// Overhang from the chuck to the tip (mm).
    pub overhang_mm: f64,
    /// Fluted length (mm).
    pub flute_length_mm: f64,
    /// Equivalent diameter of the fluted length over D (Kops & Vo 1990: 0.8).
    #[serde(default = "default_flute_ratio")]
    pub flute_diameter_ratio: f64,
    /// Young's modulus (GPa).
    #[serde(default = "default_e")]
    pub e_gpa: f64,
}

fn default_flute_ratio() -> f64 {
    0.8
}
fn default_e() -> f64 {
    CARBIDE_E_GPA
}

impl ToolOverhang {
    /// 003's Ø16 mm tool at `overhang_d` diameters of overhang (003 gives none; 3.5 D is the issue's
    /// suggestion), flute length 32 mm (2 D, DIN 6527 L for d = 16 mm).
    pub fn brecher_003(overhang_d: f64) -> Self {
        Self {
            diameter_mm: 16.0,
            overhang_mm: overhang_d * 16.0,
            flute_length_mm: 32.0,
            flute_diameter_ratio: default_flute_ratio(),
            e_gpa: default_e(),
        }
    }

    /// Tip stiffness (N/µm) of the stepped cantilever loaded at the tip:
    /// `δ/F = L_f³/(3 E I_f) + (L³ − L_f³)/(3 E I_s)`.
    ///
    /// ```
    /// use millcomp_sim::nc_axis::ToolOverhang;
    /// // Ø16 mm, 56 mm overhang (3.5 D), 32 mm flutes at 12.8 mm: 25.4 N/µm
    /// let k = ToolOverhang::brecher_003(3.5).stiffness_n_per_um().unwrap();
    /// assert!((k - 25.4).abs() < 0.1, "{k}");
    /// ```
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] for non-positive sizes or modulus.
    pub fn stiffness_n_per_um(&self) -> Result<f64, SimError> {
        check_positive("diameter_mm", self.diameter_mm)?;
        check_positive("overhang_mm", self.overhang_mm)?;
        check_nonneg("flute_length_mm", self.flute_length_mm)?;
        check_range(
            "flute_diameter_ratio",
            self.flute_diameter_ratio,
            0.1,
            1.0,
            "0.1 <= flute_diameter_ratio <= 1",
        )?;
        check_positive("e_gpa", self.e_gpa)?;
        let e = self.e_gpa * 1e3; // N/mm²
        let lf = self.flute_length_mm.min(self.overhang_mm);
        let l = self.overhang_mm;
        let i_s = PI * self.diameter_mm.powi(4) / 64.0;
        let i_f = PI * (self.flute_diameter_ratio * self.diameter_mm).powi(4) / 64.0;
        let c = lf.powi(3) / (3.0 * e * i_f) + (l.powi(3) - lf.powi(3)) / (3.0 * e * i_s);
        Ok(1e-3 / c)
    }
}

/// Machine and tool in series, the machine's stiffness varying along the blank (module doc).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NcStiffness {
    /// Mean static stiffness of the machine at the tool, k_M (N/µm).
    pub machine_n_per_um: f64,
    /// ΔkM/kM over the blank (the stiffness rises linearly by this fraction from start to end).
    pub machine_span_rel: f64,
    /// The tool.
    pub tool: ToolOverhang,
}

impl NcStiffness {
    /// Validate.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `machine_n_per_um`, `machine_span_rel` or the tool's fields.
    pub fn validate(&self) -> Result<(), SimError> {
        check_positive("machine_n_per_um", self.machine_n_per_um)?;
        check_range(
            "machine_span_rel",
            self.machine_span_rel,
            0.0,
            1.0,
            "0 <= machine_span_rel <= 1",
        )?;
        self.tool.stiffness_n_per_um()?;
        Ok(())
    }

    /// Machine stiffness (N/µm) at `x_mm` on a blank from `x0` to `x1`.
    pub fn machine_at(&self, x_mm: f64, x0: f64, x1: f64) -> f64 {
        let f = ((x_mm - x0) / (x1 - x0)).clamp(0.0, 1.0) - 0.5;
        self.machine_n_per_um * (1.0 + self.machine_span_rel * f)
    }

    /// System stiffness (N/µm) at `x_mm` (`003_…txt` eq. 2 form).
    ///
    /// # Errors
    /// As [`ToolOverhang::stiffness_n_per_um`].
    pub fn system_at(&self, x_mm: f64, x0: f64, x1: f64) -> Result<f64, SimError> {
        series_n_per_um(
            self.machine_at(x_mm, x0, x1),
            self.tool.stiffness_n_per_um()?,
        )
    }
}

/// The force platform: `gain · F + noise`, quantised.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ForcePlatform {
    /// Gain (1 = exact calibration).
    pub gain: f64,
    /// Noise σ (N).
    pub noise_n: f64,
    /// Quantisation step (N).
    pub resolution_n: f64,
}

impl ForcePlatform {
    /// A piezoelectric platform for forces of kN (assumed: σ 2 N of charge-amplifier noise and machine
    /// vibration at rest, 0.5 N steps), exactly calibrated.
    pub fn assumed() -> Self {
        Self {
            gain: 1.0,
            noise_n: 2.0,
            resolution_n: 0.5,
        }
    }

    /// Validate.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `gain`, `noise_n` or `resolution_n`.
    pub fn validate(&self) -> Result<(), SimError> {
        check_range("gain", self.gain, 0.5, 2.0, "0.5 <= gain <= 2")?;
        check_nonneg("noise_n", self.noise_n)?;
        check_nonneg("resolution_n", self.resolution_n)?;
        Ok(())
    }
}

/// The truth of the NC stage.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct NcAxisConfig {
    /// The cutting-force model (with edge forces).
    pub force: KienzleMillingModel,
    /// Machine and tool stiffness.
    pub stiffness: NcStiffness,
    /// The x (feed) axis.
    pub x_axis: AxisDynamics,
    /// The y (compensating) axis.
    pub y_axis: AxisDynamics,
    /// The force platform.
    pub platform: ForcePlatform,
    /// Stage step (s).
    pub dt_s: f64,
    /// Height above the groove floor at which the wall is traced (mm).
    pub contour_height_mm: f64,
    /// Spindle angle at t = 0 (rad).
    #[serde(default)]
    pub spindle_phase_rad: f64,
    /// Seed of the platform noise.
    #[serde(default)]
    pub seed: u64,
}

impl NcAxisConfig {
    /// Validate.
    ///
    /// # Errors
    /// The errors of each part, and `dt_s`, `contour_height_mm`.
    pub fn validate(&self) -> Result<(), SimError> {
        self.force.validate()?;
        self.stiffness.validate()?;
        self.x_axis.validate()?;
        self.y_axis.validate()?;
        self.platform.validate()?;
        check_range("dt_s", self.dt_s, 1e-6, 1e-3, "1e-6 <= dt_s <= 1e-3")?;
        check_nonneg("contour_height_mm", self.contour_height_mm)?;
        Ok(())
    }
}

/// What one stage step produced.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct NcSample {
    /// Time at the end of the step (s).
    pub t_s: f64,
    /// Actual x (mm).
    pub x_mm: f64,
    /// Actual y axis position (µm).
    pub y_axis_um: f64,
    /// Tool-tip deflection orthogonal to the feed (µm).
    pub deflection_um: f64,
    /// True orthogonal force on the tool (N).
    pub fy_n: f64,
    /// The platform's reading of it (N).
    pub fy_measured_n: f64,
    /// Actual feed per tooth (mm).
    pub fz_mm: f64,
    /// System stiffness at the tool (N/µm).
    pub stiffness_n_per_um: f64,
}

/// One point of the generated lower wall.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct WallPoint {
    /// Position along the groove (mm).
    pub x_mm: f64,
    /// Wall error (µm, + = material left).
    pub error_um: f64,
    /// The tool deflection's part of it (µm): the error without any compensation.
    pub deflection_um: f64,
    /// Time (s) of the tooth pass that generated it: within a stage step, the axes interpolated
    /// linearly over the step and the force evaluated at the pass angle.
    #[serde(default)]
    pub t_s: f64,
}

/// The steppable NC stage.
#[derive(Debug, Clone)]
pub struct NcAxisStage {
    cfg: NcAxisConfig,
    program: NcProgram,
    interp: NcInterpolator,
    steps_per_cycle: usize,
    step: usize,
    x_axis: FeedAxis,
    y_axis: FeedAxis,
    x_ref: f64,
    y_ref: f64,
    theta: f64,
    omega: f64,
    last_x: f64,
    last_y: f64,
    noise: NoiseSource,
    last_pass: i64,
    wall: Vec<WallPoint>,
    k_tool: f64,
}

impl NcAxisStage {
    /// The stage running `program` on the truth `cfg`; the interpolator holds the end for enough
    /// cycles that both axes settle.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] for invalid parts, a program the x axis cannot feed
    /// (`feed_mm_min`, `feed_changes.feed_mm_min` above `max_feed_mm_min`), or an NC cycle that is not a
    /// whole number of stage steps (`cycle_s`).
    pub fn new(cfg: NcAxisConfig, program: NcProgram) -> Result<Self, SimError> {
        cfg.validate()?;
        program.validate(cfg.x_axis.max_feed_mm_min)?;
        let ratio = program.cycle_s / cfg.dt_s;
        if (ratio - ratio.round()).abs() > 1e-6 || ratio.round() < 1.0 {
            return Err(SimError::InvalidParameter {
                name: "cycle_s",
                value: program.cycle_s,
                allowed: "a whole multiple (>= 1) of the stage step dt_s",
            });
        }
        let settle = ((0.2 / program.cycle_s).ceil()) as usize;
        let interp = NcInterpolator::new(&program, settle)?;
        let x0 = program.start_mm;
        let k_tool = cfg.stiffness.tool.stiffness_n_per_um()?;
        let steps_per_cycle = ratio.round() as usize;
        Ok(Self {
            x_axis: FeedAxis::new(&cfg.x_axis, cfg.dt_s, x0, steps_per_cycle)?,
            y_axis: FeedAxis::new(&cfg.y_axis, cfg.dt_s, 0.0, steps_per_cycle)?,
            steps_per_cycle,
            step: 0,
            x_ref: x0,
            y_ref: 0.0,
            theta: cfg.spindle_phase_rad,
            omega: 2.0 * PI * program.speed_rpm / 60.0,
            last_x: x0,
            last_y: 0.0,
            noise: NoiseSource::new(cfg.seed, cfg.platform.noise_n)?,
            last_pass: i64::MIN,
            wall: Vec::new(),
            k_tool,
            interp,
            program,
            cfg,
        })
    }

    /// The NC's interpolator (the program's references).
    pub fn interpolator(&self) -> &NcInterpolator {
        &self.interp
    }

    /// Stage steps per NC cycle.
    pub fn steps_per_cycle(&self) -> usize {
        self.steps_per_cycle
    }

    /// Index of the NC cycle the next step belongs to.
    pub fn cycle(&self) -> usize {
        self.step / self.steps_per_cycle
    }

    /// Whether the next step starts an NC cycle (the controllers' set-point is latched there).
    pub fn at_cycle_start(&self) -> bool {
        self.step % self.steps_per_cycle == 0
    }

    /// Whether the program and the settling are done.
    pub fn finished(&self) -> bool {
        self.cycle() >= self.interp.len()
    }

    /// The program.
    pub fn program(&self) -> &NcProgram {
        &self.program
    }

    /// The truth configuration.
    pub fn config(&self) -> &NcAxisConfig {
        &self.cfg
    }

    /// The wall generated so far.
    pub fn wall(&self) -> &[WallPoint] {
        &self.wall
    }

    /// The spindle's angle (rad, accumulated since the start; what the NC's spindle encoder reads).
    pub fn spindle_angle_rad(&self) -> f64 {
        self.theta
    }

    /// Actual axis positions (x mm, y µm).
    pub fn axes(&self) -> (f64, f64) {
        (self.x_axis.position(), self.y_axis.position())
    }

    /// The machine and the tool in series at `x_mm` (N/µm): [`NcStiffness::system_at`] with the tool's
    /// stiffness computed once.
    fn system_stiffness_at(&self, x_mm: f64) -> f64 {
        let km = self.cfg.stiffness.machine_at(
            x_mm,
            self.program.blank_start_mm,
            self.program.blank_end_mm,
        );
        km * self.k_tool / (km + self.k_tool)
    }

    /// One stage step. At the start of an NC cycle the x reference of that cycle and the y set-point
    /// `y_setpoint_um` (the programmed 0 plus the controller's correction) are latched; between cycle
    /// starts the argument is ignored. A non-finite set-point keeps the previous one.
    pub fn step(&mut self, y_setpoint_um: f64) -> NcSample {
        if self.at_cycle_start() {
            self.x_ref = self.interp.reference(self.cycle()).x_mm;
            if y_setpoint_um.is_finite() {
                self.y_ref = y_setpoint_um;
            }
        }
        let dt = self.cfg.dt_s;
        self.step += 1;
        let t = self.step as f64 * dt;
        let x = self.x_axis.step(self.x_ref);
        let y = self.y_axis.step(self.y_ref);
        let v = (x - self.last_x) / dt;
        let (x_prev, y_prev, theta_prev) = (self.last_x, self.last_y, self.theta);
        self.last_x = x;
        self.last_y = y;
        self.theta += self.omega * dt;
        let tool = &self.cfg.force.tool;
        let fz = (v * 60.0 / (self.program.speed_rpm * tool.teeth as f64)).max(0.0);
        let cut = CutState {
            x_center_mm: x,
            fz_mm: fz,
            ap_mm: self.program.ap_mm,
            ae_mm: self.program.ae_mm,
            blank_start_mm: self.program.blank_start_mm,
            blank_end_mm: self.program.blank_end_mm,
        };
        let fy = self.cfg.force.forces(self.theta, &cut)[1];
        let (x0, x1) = (self.program.blank_start_mm, self.program.blank_end_mm);
        let k = self.system_stiffness_at(x);
        let delta = fy / k;
        let p = &self.cfg.platform;
        let measured = quantize(p.gain * fy + self.noise.sample(), p.resolution_n);
        // the wall: a tooth passes φ = π at the contour's height
        let r = tool.radius_mm();
        let lag = self.cfg.contour_height_mm * tool.helix_deg.to_radians().tan() / r;
        let pass = ((self.theta - PI - lag) * tool.teeth as f64 / (2.0 * PI)).floor() as i64;
        if pass != self.last_pass {
            // the pass happened within this step: the wall point at its instant, the axes
            // interpolated linearly over the step and the force evaluated there
            let theta_pass = PI + lag + 2.0 * PI * pass as f64 / tool.teeth as f64;
            let w = ((theta_pass - theta_prev) / (self.theta - theta_prev)).clamp(0.0, 1.0);
            let xp = x_prev + w * (x - x_prev);
            let yp = y_prev + w * (y - y_prev);
            if self.last_pass != i64::MIN && xp >= x0 && xp <= x1 {
                let fp = self.cfg.force.forces(
                    theta_pass,
                    &CutState {
                        x_center_mm: xp,
                        ..cut
                    },
                )[1];
                let dp = fp / self.system_stiffness_at(xp);
                self.wall.push(WallPoint {
                    x_mm: xp,
                    error_um: yp + dp,
                    deflection_um: dp,
                    t_s: t - (1.0 - w) * dt,
                });
            }
            self.last_pass = pass;
        }
        NcSample {
            t_s: t,
            x_mm: x,
            y_axis_um: y,
            deflection_um: delta,
            fy_n: fy,
            fy_measured_n: measured,
            fz_mm: fz,
            stiffness_n_per_um: k,
        }
    }
}

/// A tactile contour measurement of the wall: the generated wall resampled every `spacing_mm`, the
/// probe's noise added, then the form separated from the feed marks by the ISO 16610-21 Gaussian profile
/// filter with cut-off `cutoff_mm` (0.25 mm: a standard cut-off, above the feed marks of 0.05–0.1 mm per
/// tooth and below the millimetre-long transients at the feed step and the exit).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ContourDevice {
    /// Sampling interval (mm).
    pub spacing_mm: f64,
    /// Probe noise σ (µm).
    pub noise_um: f64,
    /// Gaussian filter cut-off λc (mm).
    pub cutoff_mm: f64,
}

impl Default for ContourDevice {
    /// 10 µm spacing, 0.2 µm noise (assumed for a tactile contour instrument), λc = 0.25 mm.
    fn default() -> Self {
        Self {
            spacing_mm: 0.01,
            noise_um: 0.2,
            cutoff_mm: 0.25,
        }
    }
}

impl ContourDevice {
    /// The checks [`Self::measure`] and [`Self::linear_map`] share: the indices of the wall's finite
    /// points and the number of grid points from `from_mm` to `to_mm`.
    fn grid(
        &self,
        wall: &[WallPoint],
        from_mm: f64,
        to_mm: f64,
    ) -> Result<(Vec<usize>, usize), SimError> {
        check_positive("spacing_mm", self.spacing_mm)?;
        check_positive("cutoff_mm", self.cutoff_mm)?;
        let finite: Vec<usize> = (0..wall.len())
            .filter(|&i| wall[i].x_mm.is_finite() && wall[i].error_um.is_finite())
            .collect();
        if to_mm.partial_cmp(&from_mm) != Some(std::cmp::Ordering::Greater) || finite.len() < 2 {
            return Err(SimError::InvalidParameter {
                name: "to_mm",
                value: to_mm,
                allowed: "> from_mm, with at least two wall points",
            });
        }
        let n = ((to_mm - from_mm) / self.spacing_mm).floor() as usize + 1;
        Ok((finite, n))
    }

    /// The profile filter's weights on the sampling grid, unnormalised, and their half-width in
    /// samples: ISO 16610-21's Gaussian s(x) = exp(−π (x/(α λc))²)/(α λc), α = √(ln 2/π),
    /// truncated at ±λc.
    fn gaussian_weights(&self) -> (isize, Vec<f64>) {
        let alpha = (2f64.ln() / PI).sqrt();
        let half = (self.cutoff_mm / self.spacing_mm).ceil() as isize;
        let w = (-half..=half)
            .map(|k| {
                let x = k as f64 * self.spacing_mm / (alpha * self.cutoff_mm);
                (-PI * x * x).exp()
            })
            .collect();
        (half, w)
    }

    /// Measure the wall between `from_mm` and `to_mm`: `(x_mm, error_um)` every `spacing_mm`.
    ///
    /// ```
    /// use millcomp_sim::nc_axis::{ContourDevice, WallPoint};
    /// let wall: Vec<WallPoint> = (0..=1000)
    ///     .map(|i| WallPoint { x_mm: i as f64 * 0.05, error_um: 3.0, deflection_um: 3.0, t_s: 0.0 })
    ///     .collect();
    /// let dev = ContourDevice { noise_um: 0.0, ..ContourDevice::default() };
    /// let c = dev.measure(&wall, 1.0, 49.0, 7).unwrap();
    /// assert_eq!(c.len(), 4801);
    /// assert!(c.iter().all(|p| (p.1 - 3.0).abs() < 1e-9));
    /// ```
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] naming `spacing_mm`, `cutoff_mm`, `noise_um`, or `to_mm` when the
    /// range is empty or the wall has fewer than two points in it.
    pub fn measure(
        &self,
        wall: &[WallPoint],
        from_mm: f64,
        to_mm: f64,
        seed: u64,
    ) -> Result<Vec<(f64, f64)>, SimError> {
        check_nonneg("noise_um", self.noise_um)?;
        let (finite, n) = self.grid(wall, from_mm, to_mm)?;
        let pts: Vec<(f64, f64)> = finite
            .iter()
            .map(|&i| (wall[i].x_mm, wall[i].error_um))
            .collect();
        let mut noise = NoiseSource::new(seed, self.noise_um)?;
        let mut raw = Vec::with_capacity(n);
        let mut j = 0usize;
        for i in 0..n {
            let x = from_mm + i as f64 * self.spacing_mm;
            while j + 1 < pts.len() - 1 && pts[j + 1].0 < x {
                j += 1;
            }
            let (a, b) = (pts[j], pts[(j + 1).min(pts.len() - 1)]);
            let y = if b.0 > a.0 {
                let w = ((x - a.0) / (b.0 - a.0)).clamp(0.0, 1.0);
                a.1 + w * (b.1 - a.1)
            } else {
                a.1
            };
            raw.push(y + noise.sample());
        }
        let (half, w) = self.gaussian_weights();
        let mut out = Vec::with_capacity(n);
        for i in 0..n as isize {
            let (mut s, mut sw) = (0.0, 0.0);
            for (kk, wk) in w.iter().enumerate() {
                let m = i + kk as isize - half;
                if m >= 0 && (m as usize) < n {
                    s += wk * raw[m as usize];
                    sw += wk;
                }
            }
            out.push((from_mm + i as f64 * self.spacing_mm, s / sw));
        }
        Ok(out)
    }

    /// [`Self::measure`] without its noise as a linear map of the wall points' errors: row `i` (the
    /// contour at `from_mm + i·spacing_mm`) lists `(index into wall, weight)` such that the noise-free
    /// measurement is `Σ weight · wall[index].error_um` — the interpolation onto the grid and the
    /// Gaussian filter, both linear. Points with a non-finite position or error are skipped, as
    /// [`Self::measure`] skips them. A measurement with noise is this map plus the measurement of a
    /// zero wall with the same seed.
    ///
    /// ```
    /// use millcomp_sim::nc_axis::{ContourDevice, WallPoint};
    /// let wall: Vec<WallPoint> = (0..=200)
    ///     .map(|i| WallPoint { x_mm: i as f64 * 0.05, error_um: (i as f64).sin(), deflection_um: 0.0, t_s: 0.0 })
    ///     .collect();
    /// let dev = ContourDevice { noise_um: 0.0, ..ContourDevice::default() };
    /// let c = dev.measure(&wall, 1.0, 9.0, 7).unwrap();
    /// let map = dev.linear_map(&wall, 1.0, 9.0).unwrap();
    /// for (row, (_, y)) in map.iter().zip(&c) {
    ///     let v: f64 = row.iter().map(|&(j, w)| w * wall[j].error_um).sum();
    ///     assert!((v - y).abs() < 1e-12);
    /// }
    /// ```
    ///
    /// # Errors
    /// As [`Self::measure`].
    pub fn linear_map(
        &self,
        wall: &[WallPoint],
        from_mm: f64,
        to_mm: f64,
    ) -> Result<Vec<Vec<(usize, f64)>>, SimError> {
        let (finite, n) = self.grid(wall, from_mm, to_mm)?;
        let pts: Vec<(usize, f64)> = finite.iter().map(|&i| (i, wall[i].x_mm)).collect();
        // the interpolation of each grid point: (wall index, weight) × 2
        let mut raw: Vec<[(usize, f64); 2]> = Vec::with_capacity(n);
        let mut j = 0usize;
        for i in 0..n {
            let x = from_mm + i as f64 * self.spacing_mm;
            while j + 1 < pts.len() - 1 && pts[j + 1].1 < x {
                j += 1;
            }
            let (a, b) = (pts[j], pts[(j + 1).min(pts.len() - 1)]);
            raw.push(if b.1 > a.1 {
                let w = ((x - a.1) / (b.1 - a.1)).clamp(0.0, 1.0);
                [(a.0, 1.0 - w), (b.0, w)]
            } else {
                [(a.0, 1.0), (b.0, 0.0)]
            });
        }
        let (half, w) = self.gaussian_weights();
        let mut out = Vec::with_capacity(n);
        for i in 0..n as isize {
            let mut row: Vec<(usize, f64)> = Vec::new();
            let mut sw = 0.0;
            for (kk, wk) in w.iter().enumerate() {
                let m = i + kk as isize - half;
                if m >= 0 && (m as usize) < n {
                    sw += wk;
                    for &(idx, c) in &raw[m as usize] {
                        if c != 0.0 {
                            match row.iter_mut().find(|(r, _)| *r == idx) {
                                Some(e) => e.1 += wk * c,
                                None => row.push((idx, wk * c)),
                            }
                        }
                    }
                }
            }
            for e in &mut row {
                e.1 /= sw;
            }
            out.push(row);
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kienzle::{EdgeForces, EndMill, KienzleCoefficients};

    fn truth() -> NcAxisConfig {
        NcAxisConfig {
            force: KienzleMillingModel {
                coefficients: KienzleCoefficients::c45_handbook(),
                edge: EdgeForces::c45_assumed(),
                tool: EndMill::brecher_003(),
                axial_slices: 8,
            },
            stiffness: NcStiffness {
                machine_n_per_um: 30.0,
                machine_span_rel: 0.0,
                tool: ToolOverhang::brecher_003(3.5),
            },
            x_axis: AxisDynamics::brecher_003(),
            y_axis: AxisDynamics::brecher_003(),
            platform: ForcePlatform {
                noise_n: 0.0,
                resolution_n: 0.0,
                gain: 1.0,
            },
            dt_s: STAGE_DT_S,
            contour_height_mm: 1.0,
            spindle_phase_rad: 0.0,
            seed: 1,
        }
    }

    /// A short program: constant 500 mm/min over a 30 mm blank.
    fn short_program() -> NcProgram {
        NcProgram {
            feed_changes: vec![],
            blank_end_mm: 30.0,
            end_mm: 40.0,
            ..NcProgram::brecher_003()
        }
    }

    #[test]
    fn the_axis_lags_a_ramp_by_16_ms() {
        let d = AxisDynamics::brecher_003();
        let mut ax = FeedAxis::new(&d, 1e-4, 0.0, 1).unwrap();
        let v = 10.0; // mm/s
        let mut last = 0.0;
        for k in 0..20_000 {
            last = ax.step(v * k as f64 * 1e-4);
        }
        let lag = (v * 19_999.0 * 1e-4 - last) / v;
        // ramp following error of dead time + kv/(Tv s² + s + kv): T_d + 1/kv (+ one ZOH half-step)
        assert!((lag - 0.016).abs() < 2e-4, "{lag}");
    }

    /// The axis' velocity (mm/s) at each stage step of the last two cycles and its lag (s) behind a
    /// ramp of 10 mm/s whose set-points are latched every 20 stage steps (2 ms at 0.1 ms).
    fn held_ramp(d: &AxisDynamics) -> (Vec<f64>, f64) {
        let (dt, n, v) = (1e-4, 20, 10.0);
        let mut ax = FeedAxis::new(d, dt, 0.0, n).unwrap();
        let (mut last, mut vel) = (0.0, Vec::new());
        let steps = 20_000;
        for k in 0..steps {
            let r = v * (k / n * n) as f64 * dt; // the cycle's set-point, held
            let y = ax.step(r);
            if k >= steps - 2 * n {
                vel.push((y - last) / dt);
            }
            last = y;
        }
        (vel, (v * (steps - 1) as f64 * dt - last) / v)
    }

    #[test]
    fn fine_interpolation_keeps_the_feed_constant_within_a_cycle() {
        // held set-points: the 4 ms loop follows the 2 ms staircase, the feed pulsates (±6 %); fine
        // interpolation hands the loop a ramp: the feed is the programmed 10 mm/s to 1e-6
        let ff = AxisDynamics::speed_feedforward_003();
        let (vel, lag) = held_ramp(&ff);
        for w in &vel {
            assert!((w - 10.0).abs() < 1e-6, "{w}");
        }
        // behind the continuous ramp: the interpolation's whole cycle (less one step), 11 ms dead
        // time, 1/kv = 4 ms: 17 ms, the equivalent delay (16 ms, from a held set-point) + T/2
        assert!(
            (lag - (ff.equivalent_delay_s(0.002) + 0.001 - 1e-4)).abs() < 2e-4,
            "{lag}"
        );
        let held = AxisDynamics {
            fine_interpolation: false,
            ..ff
        };
        let (vel, _) = held_ramp(&held);
        let (lo, hi) = vel
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &w| {
                (a.min(w), b.max(w))
            });
        // 9.29 .. 10.41 mm/s: ±6 % of the feed, one chip per tooth thicker or thinner by as much
        assert!(hi - lo > 0.5, "{lo} .. {hi}");
    }

    /// The 10 % and 90 % crossing times (s) of `d`'s response to a unit position step at 0.
    fn step_crossings(d: &AxisDynamics) -> (f64, f64) {
        let dt = 1e-5;
        let mut ax = FeedAxis::new(d, dt, 0.0, 1).unwrap();
        let (mut t10, mut t90) = (f64::NAN, f64::NAN);
        for k in 1..10_000 {
            let y = ax.step(1.0);
            let t = k as f64 * dt;
            if t10.is_nan() && y >= 0.1 {
                t10 = t;
            }
            if y >= 0.9 {
                t90 = t;
                break;
            }
        }
        (t10, t90)
    }

    #[test]
    fn the_feedforward_axis_is_mostly_dead_time() {
        // the loop kv/(Tv s² + s + kv) with kv = 250, Tv = 1 ms is (500/(s + 500))²: its step
        // response 1 − (1 + a t) e^{−a t}, a = 500 1/s, crosses 10 % at a t = 0.5318 and 90 % at
        // a t = 3.8897 (the roots of that expression), after the 11 ms dead time (one set-point per
        // step: the fine interpolation has nothing to interpolate)
        let (t10, t90) = step_crossings(&AxisDynamics::speed_feedforward_003());
        assert!((t10 - (0.011 + 0.5318 / 500.0)).abs() < 3e-5, "{t10}");
        assert!((t90 - (0.011 + 3.8897 / 500.0)).abs() < 3e-5, "{t90}");
        // the P loop: poles at 250 ∓ √(250² − 41 667) = 105.66 and 394.34 1/s after 4 ms, its
        // 10–90 % rise 22.0 ms (the step response of two real poles, solved numerically) against
        // 6.7 ms: the same 16 ms for a ramp, three times slower to follow a step
        let (s10, s90) = step_crossings(&AxisDynamics::brecher_003());
        let (p1, p2) = (105.662_f64, 394.338_f64);
        let y = |t: f64| 1.0 - (p2 * (-p1 * t).exp() - p1 * (-p2 * t).exp()) / (p2 - p1);
        let cross = |level: f64| {
            let (mut lo, mut hi) = (0.0, 0.2);
            for _ in 0..60 {
                let mid = 0.5 * (lo + hi);
                if y(mid) < level { lo = mid } else { hi = mid }
            }
            lo
        };
        assert!((s10 - (0.004 + cross(0.1))).abs() < 3e-5, "{s10}");
        assert!((s90 - (0.004 + cross(0.9))).abs() < 3e-5, "{s90}");
        assert!((s90 - s10 - 0.0220).abs() < 2e-4, "{}", s90 - s10);
    }

    #[test]
    fn uncompensated_wall_follows_force_over_stiffness() {
        let p = short_program();
        let mut st = NcAxisStage::new(truth(), p).unwrap();
        let mut s = Vec::new();
        while !st.finished() {
            s.push(st.step(0.0));
        }
        let wall = st.wall().to_vec();
        let mid: Vec<&WallPoint> = wall
            .iter()
            .filter(|w| w.x_mm > 12.0 && w.x_mm < 20.0)
            .collect();
        let mean = mid.iter().map(|w| w.error_um).sum::<f64>() / mid.len() as f64;
        // the steady mean force over the system stiffness, from the same model
        let m = &truth().force;
        let fy = m.mean_forces(500.0 / (1990.0 * 5.0), 8.0, 16.0)[1];
        let k = truth().stiffness.system_at(15.0, 0.0, 30.0).unwrap();
        // the wall is sampled at the tooth passes, not averaged: within 10 % of F̄/k
        assert!((mean - fy / k).abs() < 0.1 * fy / k, "{mean} vs {}", fy / k);
        // wall points one per tooth pass: fz = 0.05 mm apart
        let dx = mid[1].x_mm - mid[0].x_mm;
        assert!((dx - 0.0503).abs() < 0.002, "{dx}");
        assert!(s.iter().all(|x| x.fy_measured_n == x.fy_n));
    }

    #[test]
    fn the_wall_is_cut_at_the_pass_instants_not_at_the_stage_steps() {
        // a tooth passes the wall between two 0.1 ms steps: its wall point is at the pass instant —
        // the spindle at the pass angle, the force there over the stiffness there — not at the step
        // after it (at the exit the wall force falls by a third within 0.05 mm, 3 ms: a step late
        // was 1–2 µm)
        let p = short_program();
        let cfg = truth();
        let mut st = NcAxisStage::new(cfg.clone(), p.clone()).unwrap();
        while !st.finished() {
            st.step(0.0);
        }
        let tool = &cfg.force.tool;
        let lag = cfg.contour_height_mm * tool.helix_deg.to_radians().tan() / tool.radius_mm();
        let omega = 2.0 * PI * p.speed_rpm / 60.0;
        let pitch = 2.0 * PI / tool.teeth as f64;
        let mut off_step = 0;
        for w in st.wall() {
            let theta = cfg.spindle_phase_rad + omega * w.t_s;
            // the pass angle, to rounding
            let k = ((theta - PI - lag) / pitch).round();
            assert!((theta - (PI + lag + k * pitch)).abs() < 1e-9, "{}", w.t_s);
            if ((w.t_s / cfg.dt_s) - (w.t_s / cfg.dt_s).round()).abs() > 1e-3 {
                off_step += 1;
            }
        }
        // the passes fall between the steps (almost never on one)
        assert!(off_step > st.wall().len() * 9 / 10, "{off_step}");
        // and the deflection is the force at that instant over the stiffness: one point checked
        let w = st.wall()[st.wall().len() / 2];
        let theta = cfg.spindle_phase_rad + omega * w.t_s;
        let fz = 500.0 / (p.speed_rpm * tool.teeth as f64);
        let f = cfg.force.forces(
            theta,
            &CutState {
                x_center_mm: w.x_mm,
                fz_mm: fz,
                ap_mm: p.ap_mm,
                ae_mm: p.ae_mm,
                blank_start_mm: p.blank_start_mm,
                blank_end_mm: p.blank_end_mm,
            },
        )[1];
        let k = cfg.stiffness.system_at(w.x_mm, 0.0, 30.0).unwrap();
        assert!(
            (w.deflection_um - f / k).abs() < 1e-3 * w.deflection_um,
            "{} vs {}",
            w.deflection_um,
            f / k
        );
    }

    #[test]
    fn the_cycle_must_divide() {
        let p = NcProgram {
            cycle_s: 0.00215,
            ..NcProgram::brecher_003()
        };
        let e = NcAxisStage::new(truth(), p).unwrap_err();
        assert!(e.to_string().contains("cycle_s"), "{e}");
        let p = NcProgram {
            feed_changes: vec![NcFeedChange {
                x_mm: 90.0,
                feed_mm_min: 40_000.0,
            }],
            ..NcProgram::brecher_003()
        };
        let e = NcAxisStage::new(truth(), p).unwrap_err();
        assert!(e.to_string().contains("feed_changes.feed_mm_min"), "{e}");
    }
}

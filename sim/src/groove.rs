//! The groove stage (`000_…txt` ch. 6–7): a full-immersion slot with a programmed depth profile, cut by a
//! tilted ball-end mill on the PZT-actuated spindle, as a steppable plant.
//!
//! Per step of `dt_s`:
//! 1. the PZT spindle receives the actuator command (V) and moves the tool tip radially by `tip_um`
//!    (+ = towards the work); its z-component is `tip_um · sin α` (eq. 26);
//! 2. the actual depth at the tool's x is `d = d_cmd − δz + tip_um·sin α + o(x)`, clamped to `[0, R]`
//!    (**sign convention: every term in µm, + = deeper groove**), with `o(x)` the machine's own depth
//!    offset along the path ([`PathOffset`]: a guideway that is not straight; none by default);
//! 3. the cutting force at the current rotation angle follows from the force model at depth `d`;
//! 4. the z-deflection `δz = Fz,peak/kz` uses the peak z-force over the last revolution — the thesis'
//!    assumption that "the maximum force corresponds to the maximum deflection, or maximum error" (§6.2) —
//!    and is applied from the next step on (explicit; the loop gain ∂Fz/∂d/kz ≈ 0.2 keeps it stable);
//! 5. sensors: workpiece z-force (Kistler, §7.2), raw spindle y-force (§7.3: `Fz cos α / 2.28 +
//!    0.44 N/µm · tip`), capacitance gauge on the tip displacement.
//!
//! The groove profile is the depth cut at each x (the bottom left behind the tool).

use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

use crate::error::{SimError, check_finite, check_positive, check_range};
use crate::feed::{FeedChange, FeedProfile, WorkpieceExit};
use crate::filters::SlidingMax;
use crate::force::{
    BallEndForceModel, CutConditions, ForceParams, PreparedCut, S7_GROOVE_FORCE_SCALE,
};
use crate::material::Material;
use crate::sensors::{CapacitanceGauge, ForceSensor, InstrumentErrors, NoiseSpec};
use crate::spindle::{DiscretePztSpindle, PztSpindle, SpindleStep};
use crate::stiffness::TiltedToolStiffness;
use crate::tool::BallEndTool;

/// Static calibration from the spindle transducer's y-reading to the axial tool force (eq. 31, 2.28).
pub const SPINDLE_Y_CALIBRATION: f64 = 2.28;

/// An additive depth offset along the groove path (µm, **+ = deeper**), tabulated at increasing `x` (mm)
/// and linear between the points, constant before the first and after the last: a depth the cut gains
/// or loses at each position whatever the tool does — a guideway that is not straight under the path,
/// in the truth ([`GrooveConfig::path_offset`]); or what a controller was told of such an effect (a
/// diagnosed one, tabulated along its program). Empty: no offset.
///
/// # Examples
/// ```
/// use millcomp_sim::groove::PathOffset;
/// let o = PathOffset::new(vec![(0.0, 0.0), (2.0, -1.0), (4.0, 0.0)]).unwrap();
/// assert_eq!(o.at(1.0), -0.5);
/// assert_eq!(o.at(-3.0), 0.0); // constant beyond the ends
/// assert_eq!(PathOffset::default().at(1.0), 0.0);
/// assert!(PathOffset::new(vec![(1.0, 0.0), (0.5, 1.0)]).is_err()); // not increasing
/// ```
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct PathOffset {
    /// `(x_mm, offset_um)`, strictly increasing in x.
    points: Vec<(f64, f64)>,
}

impl PathOffset {
    /// A table of `(x_mm, offset_um)` points.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] (`path_offset`) for a non-finite value or x that does not strictly
    /// increase.
    pub fn new(points: Vec<(f64, f64)>) -> Result<Self, SimError> {
        let o = Self { points };
        o.validate()?;
        Ok(o)
    }

    /// Checks the table (finite values, strictly increasing x).
    ///
    /// # Errors
    /// As [`Self::new`].
    pub fn validate(&self) -> Result<(), SimError> {
        for (i, &(x, v)) in self.points.iter().enumerate() {
            check_finite("path_offset", x)?;
            check_finite("path_offset", v)?;
            if i > 0 && x <= self.points[i - 1].0 {
                return Err(SimError::InvalidParameter {
                    name: "path_offset",
                    value: x,
                    allowed: "x_mm strictly increasing along the table",
                });
            }
        }
        Ok(())
    }

    /// No offset anywhere.
    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    /// The table's points.
    pub fn points(&self) -> &[(f64, f64)] {
        &self.points
    }

    /// The offset (µm) at `x_mm`.
    pub fn at(&self, x_mm: f64) -> f64 {
        let p = &self.points;
        match p.len() {
            0 => 0.0,
            _ if x_mm <= p[0].0 => p[0].1,
            n if x_mm >= p[n - 1].0 => p[n - 1].1,
            _ => {
                // first point with x > x_mm (1 ≤ i ≤ n − 1 here)
                let i = p.partition_point(|q| q.0 <= x_mm);
                let ((x0, y0), (x1, y1)) = (p[i - 1], p[i]);
                y0 + (y1 - y0) * (x_mm - x0) / (x1 - x0)
            }
        }
    }
}

/// Programmed depth along a groove.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum DepthProfile {
    /// Linear ramp from `from_um` at x = 0 to `to_um` at the end of the groove.
    Ramp {
        /// Depth at x = 0 (µm).
        from_um: f64,
        /// Depth at x = length (µm).
        to_um: f64,
    },
    /// Constant depth.
    Constant {
        /// Depth (µm).
        depth_um: f64,
    },
    /// Piecewise-constant steps: `(x_start_mm, depth_um)`, sorted by x; before the first step the depth is 0.
    /// An instantaneous step in depth is an idealisation: a machine's z-axis needs time to plunge (use
    /// [`DepthProfile::Points`] for a programmed plunge slope).
    Steps {
        /// Step starts and depths.
        steps: Vec<(f64, f64)>,
    },
    /// Piecewise-linear through `(x_mm, depth_um)` points, sorted by x; constant before the first and after
    /// the last point (an NC program's depth at each block end).
    Points {
        /// Points along the groove.
        points: Vec<(f64, f64)>,
    },
}

impl DepthProfile {
    /// Programmed depth (µm) at `x_mm` for a groove of `length_mm`.
    pub fn depth_at(&self, x_mm: f64, length_mm: f64) -> f64 {
        match self {
            DepthProfile::Ramp { from_um, to_um } => {
                let s = if length_mm > 0.0 {
                    (x_mm / length_mm).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                from_um + (to_um - from_um) * s
            }
            DepthProfile::Constant { depth_um } => *depth_um,
            DepthProfile::Steps { steps } => steps
                .iter()
                .take_while(|(x0, _)| *x0 <= x_mm)
                .last()
                .map(|(_, d)| *d)
                .unwrap_or(0.0),
            DepthProfile::Points { points } => {
                let Some(&(x_first, d_first)) = points.first() else {
                    return 0.0;
                };
                if x_mm <= x_first {
                    return d_first;
                }
                for w in points.windows(2) {
                    let ((x0, d0), (x1, d1)) = (w[0], w[1]);
                    if x_mm <= x1 {
                        return if x1 > x0 {
                            d0 + (d1 - d0) * (x_mm - x0) / (x1 - x0)
                        } else {
                            d1
                        };
                    }
                }
                points.last().map(|p| p.1).unwrap_or(0.0)
            }
        }
    }

    /// Positions (mm) inside the groove where the programmed depth changes abruptly or its slope changes:
    /// the starts of steps and the interior points of a point list (process changes a controller can
    /// preview).
    pub fn change_points_mm(&self) -> Vec<f64> {
        match self {
            DepthProfile::Steps { steps } => {
                steps.iter().map(|p| p.0).filter(|x| *x > 0.0).collect()
            }
            DepthProfile::Points { points } if points.len() > 2 => {
                points[1..points.len() - 1].iter().map(|p| p.0).collect()
            }
            _ => Vec::new(),
        }
    }

    /// Validate: depths within `[0, max_depth_um]`, steps sorted.
    pub fn validate(&self, max_depth_um: f64) -> Result<(), SimError> {
        let chk = |d: f64| {
            check_range(
                "depth_um",
                d,
                0.0,
                max_depth_um,
                "0 <= depth_um <= tool radius_um",
            )
        };
        match self {
            DepthProfile::Ramp { from_um, to_um } => {
                chk(*from_um)?;
                chk(*to_um)?;
            }
            DepthProfile::Constant { depth_um } => {
                chk(*depth_um)?;
            }
            DepthProfile::Steps { steps: pts } | DepthProfile::Points { points: pts } => {
                let name = if matches!(self, DepthProfile::Steps { .. }) {
                    "steps.x_mm"
                } else {
                    "points.x_mm"
                };
                if pts.is_empty() {
                    return Err(SimError::InvalidParameter {
                        name,
                        value: 0.0,
                        allowed: "at least one (x_mm, depth_um) pair",
                    });
                }
                let mut last = f64::NEG_INFINITY;
                for (x, d) in pts {
                    if !x.is_finite() || *x < last {
                        return Err(SimError::InvalidParameter {
                            name,
                            value: *x,
                            allowed: "finite and non-decreasing",
                        });
                    }
                    last = *x;
                    chk(*d)?;
                }
            }
        }
        Ok(())
    }
}

/// Which force signal the stage reports as `force_meas_n`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ForceChannel {
    /// Workpiece z-force (Kistler under the part, §7.2).
    #[default]
    WorkpieceZ,
    /// Calibrated spindle axial force converted to workpiece z: `(raw − 0.44·tip)·2.28/cos α` (§7.3).
    SpindleCalibrated,
}

/// The planned process of a groove — what the NC program and the part drawing say: spindle speed, feed
/// and its programmed changes, tool tilt, path length, programmed depth and where the workpiece ends.
/// The controllers plan with it (they never see the rest of [`GrooveConfig`], the truth plant); the stage
/// cuts it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GrooveProgram {
    /// Spindle speed (rpm).
    pub speed_rpm: f64,
    /// Upfeed (µm/rev).
    pub upfeed_um: f64,
    /// Tool tilt (deg).
    pub tilt_deg: f64,
    /// Groove length (mm).
    pub length_mm: f64,
    /// Programmed depth profile.
    pub depth_profile: DepthProfile,
    /// Programmed feed changes along the groove (none: constant `upfeed_um`).
    #[serde(default)]
    pub feed_changes: Vec<FeedChange>,
    /// Feed-axis acceleration (mm/s²) with which feed changes are executed (`003_…txt` §3.2).
    #[serde(default = "default_feed_accel")]
    pub feed_accel_mm_s2: f64,
    /// Workpiece edge where the tool leaves the material (none: material over the whole length).
    #[serde(default)]
    pub exit: Option<WorkpieceExit>,
    /// Approach in air before the workpiece (mm, default 0): the tool starts at x = −approach at the
    /// programmed feed and depth and enters the material at x = 0 — the NC program's lead-in, during
    /// which a controller that knows the program can pre-position its actuator.
    #[serde(default)]
    pub approach_mm: f64,
    /// Length (mm) after the entry over which the engagement rises linearly from 0 to 1 (default 0: at
    /// once) — the part of the tool's contact zone already in the material, as for the exit.
    #[serde(default)]
    pub entry_length_mm: f64,
}

/// Groove stage configuration: the truth plant (force model, stiffness, spindle, sensors) and the
/// [`GrooveProgram`] it cuts (serialised flat, one level with the plant's keys).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct GrooveConfig {
    /// Force model (material, tool, constants).
    pub force_model: BallEndForceModel,
    /// Tool/spindle stiffness.
    pub stiffness: TiltedToolStiffness,
    /// PZT spindle plant.
    pub spindle: PztSpindle,
    /// The planned process: speed, feed, tilt, length, depth profile, feed changes, exit.
    #[serde(flatten)]
    pub program: GrooveProgram,
    /// Force channel reported as `force_meas_n`.
    pub force_channel: ForceChannel,
    /// Optional force-sensor noise (σ in N; quantisation 0.04 N when present, §5.2.2).
    pub force_noise: Option<NoiseSpec>,
    /// Optional gauge noise (σ in µm).
    pub gauge_noise: Option<NoiseSpec>,
    /// Errors of the instruments and of the set-up that no model of the plant contains (force-sensor
    /// gain and drift, touch-off, gauge zero); exact by default.
    #[serde(default)]
    pub instruments: InstrumentErrors,
    /// The machine's own depth offset along the path (a guideway that is not straight under it), added to
    /// the depth cut at every x; none by default.
    #[serde(default, skip_serializing_if = "PathOffset::is_empty")]
    pub path_offset: PathOffset,
}

/// Default feed-axis acceleration (mm/s²) for feed changes: 100 mm/s² (≈ 0.01 g), the path acceleration of
/// a jerk-limited NC feed change at micro-milling feeds — an assumption (003 does not give the value; it
/// only states that the axes follow a feed step "in a delayed manner"). A doubling from 1.67 to 3.33 mm/s
/// then takes 17 ms (≈ 3 spindle revolutions at 10 000 rpm).
pub const DEFAULT_FEED_ACCEL_MM_S2: f64 = 100.0;

fn default_feed_accel() -> f64 {
    DEFAULT_FEED_ACCEL_MM_S2
}

/// Check an entry's engagement length against a cut of `length_mm`: `0 <= entry_length_mm < length_mm`.
///
/// # Errors
/// [`SimError::InvalidParameter`] naming `entry_length_mm`.
pub fn check_entry_length(entry_length_mm: f64, length_mm: f64) -> Result<(), SimError> {
    if entry_length_mm.is_finite() && entry_length_mm >= 0.0 && entry_length_mm < length_mm {
        Ok(())
    } else {
        Err(SimError::InvalidParameter {
            name: "entry_length_mm",
            value: entry_length_mm,
            allowed: "0 <= entry_length_mm < length_mm",
        })
    }
}

impl GrooveProgram {
    /// The thesis' groove program: 0–80 µm over 20 mm, 10 000 rpm, 10 µm/rev, tilt `tilt_deg`, no feed
    /// changes, no exit (unchecked; [`GrooveProgram::validate`] checks).
    ///
    /// ```
    /// use millcomp_sim::groove::GrooveProgram;
    /// let p = GrooveProgram::thesis(20.0);
    /// // 20 mm at 10 µm/rev and 10 000 rpm (1.667 mm/s): 12 s of cut, full engagement
    /// assert!((p.duration_s() - 12.0).abs() < 1e-9);
    /// assert_eq!(p.engagement(19.9), 1.0);
    /// ```
    pub fn thesis(tilt_deg: f64) -> Self {
        Self {
            speed_rpm: 10_000.0,
            upfeed_um: 10.0,
            tilt_deg,
            length_mm: 20.0,
            depth_profile: DepthProfile::Ramp {
                from_um: 0.0,
                to_um: 80.0,
            },
            feed_changes: Vec::new(),
            feed_accel_mm_s2: DEFAULT_FEED_ACCEL_MM_S2,
            exit: None,
            approach_mm: 0.0,
            entry_length_mm: 0.0,
        }
    }

    /// Validate the program for a tool that can cut at most `max_depth_um` deep (its ball radius);
    /// errors name the parameter.
    pub fn validate(&self, max_depth_um: f64) -> Result<(), SimError> {
        // speed, upfeed and tilt: the cut conditions' own checks
        self.conditions(0.0).validate()?;
        check_positive("length_mm", self.length_mm)?;
        self.depth_profile.validate(max_depth_um)?;
        self.feed_profile()?;
        check_entry_length(self.entry_length_mm, self.length_mm)?;
        if let Some(e) = &self.exit {
            e.validate(self.length_mm)?;
        }
        Ok(())
    }

    /// Feed velocity (mm/s) at the start of the cut.
    pub fn feed_mm_s(&self) -> f64 {
        self.upfeed_um * self.speed_rpm * 1e-3 / 60.0
    }

    /// The feed motion (programmed feed, its changes and the axis acceleration).
    pub fn feed_profile(&self) -> Result<FeedProfile, SimError> {
        FeedProfile::with_approach(
            self.length_mm,
            self.speed_rpm,
            self.upfeed_um,
            &self.feed_changes,
            self.feed_accel_mm_s2,
            self.approach_mm,
        )
    }

    /// Duration of the cut (s).
    pub fn duration_s(&self) -> f64 {
        self.feed_profile()
            .map(|p| p.duration_s())
            .unwrap_or_else(|_| self.length_mm / self.feed_mm_s())
    }

    /// Programmed depth (µm) at `x_mm` (on the approach, x < 0: the depth at the entry — the z-axis is
    /// already there).
    pub fn depth_at(&self, x_mm: f64) -> f64 {
        self.depth_profile.depth_at(x_mm.max(0.0), self.length_mm)
    }

    /// Engagement (0…1) of the tool with the material at `x_mm`: 0 on the approach (x < 0), rising over
    /// `entry_length_mm`, then 1 up to the exit's drop (1 everywhere without an exit).
    ///
    /// ```
    /// use millcomp_sim::groove::GrooveProgram;
    /// let p = GrooveProgram { approach_mm: 0.5, ..GrooveProgram::thesis(20.0) };
    /// assert_eq!((p.engagement(-0.1), p.engagement(0.0)), (0.0, 1.0));
    /// let p = GrooveProgram { entry_length_mm: 0.2, ..p };
    /// assert!((p.engagement(0.05) - 0.25).abs() < 1e-12);
    /// ```
    pub fn engagement(&self, x_mm: f64) -> f64 {
        if x_mm < 0.0 {
            return 0.0;
        }
        let entry = if self.entry_length_mm > 0.0 {
            (x_mm / self.entry_length_mm).min(1.0)
        } else {
            1.0
        };
        entry * self.exit.map(|e| e.engagement(x_mm)).unwrap_or(1.0)
    }

    /// Cut conditions at `depth_um` and the starting upfeed.
    pub fn conditions(&self, depth_um: f64) -> CutConditions {
        self.conditions_at(depth_um, self.upfeed_um)
    }

    /// Cut conditions at `depth_um` and `upfeed_um`.
    pub fn conditions_at(&self, depth_um: f64, upfeed_um: f64) -> CutConditions {
        CutConditions {
            depth_um,
            upfeed_um,
            speed_rpm: self.speed_rpm,
            tilt_deg: self.tilt_deg,
        }
    }
}

impl GrooveConfig {
    /// The thesis' groove: S7, 0–80 µm over 20 mm, 10 000 rpm, 10 µm/rev, tilt `tilt_deg`, long (4 mm shank)
    /// tool with wearland `wearland_um` (§6.2 simulation: 8 µm; the measured grooves of Fig. 7-9: 5 µm) and
    /// runout 10 µm, measured stiffness, force scale [`S7_GROOVE_FORCE_SCALE`].
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`]: `wearland_um` outside `[0, 400]` µm (the ball radius) or
    /// `tilt_deg` outside `0 <= tilt_deg < 90`. Example in the crate documentation.
    pub fn thesis(tilt_deg: f64, wearland_um: f64) -> Result<Self, SimError> {
        let c = Self {
            force_model: BallEndForceModel::new(
                Material::s7(),
                BallEndTool::new(400.0, wearland_um, 10.0)?,
                ForceParams {
                    force_scale: S7_GROOVE_FORCE_SCALE,
                    ..ForceParams::default()
                },
            )?,
            stiffness: TiltedToolStiffness::default(),
            spindle: PztSpindle::default(),
            program: GrooveProgram::thesis(tilt_deg),
            force_channel: ForceChannel::WorkpieceZ,
            force_noise: None,
            gauge_noise: None,
            instruments: InstrumentErrors::default(),
            path_offset: PathOffset::default(),
        };
        c.validate()?;
        Ok(c)
    }

    /// Validate everything (errors name the parameter).
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] from [`BallEndForceModel::validate`],
    /// [`TiltedToolStiffness::validate`], [`PztSpindle::validate`] or [`GrooveProgram::validate`].
    pub fn validate(&self) -> Result<(), SimError> {
        self.force_model.validate()?;
        self.stiffness.validate()?;
        self.spindle.validate()?;
        self.instruments.validate()?;
        self.path_offset.validate()?;
        self.program.validate(self.force_model.tool.radius_um)
    }

    /// Feed velocity (mm/s) at the start of the cut ([`GrooveProgram::feed_mm_s`]).
    pub fn feed_mm_s(&self) -> f64 {
        self.program.feed_mm_s()
    }

    /// The feed motion ([`GrooveProgram::feed_profile`]).
    pub fn feed_profile(&self) -> Result<FeedProfile, SimError> {
        self.program.feed_profile()
    }

    /// Duration of the cut (s) ([`GrooveProgram::duration_s`]).
    pub fn duration_s(&self) -> f64 {
        self.program.duration_s()
    }

    /// Engagement (0…1) at `x_mm` ([`GrooveProgram::engagement`]).
    pub fn engagement(&self, x_mm: f64) -> f64 {
        self.program.engagement(x_mm)
    }

    /// Cut conditions at `depth_um` and the starting upfeed ([`GrooveProgram::conditions`]).
    pub fn conditions(&self, depth_um: f64) -> CutConditions {
        self.program.conditions(depth_um)
    }

    /// Cut conditions at `depth_um` and `upfeed_um` ([`GrooveProgram::conditions_at`]).
    pub fn conditions_at(&self, depth_um: f64, upfeed_um: f64) -> CutConditions {
        self.program.conditions_at(depth_um, upfeed_um)
    }

    /// Quasi-static (per-revolution peak) uncompensated z-deflection (µm) at programmed depth
    /// `depth_cmd_um`, solved self-consistently: `δ = Fz,peak(d_cmd − δ)/kz` by fixed-point iteration.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`]: the program's `tilt_deg` outside `[0, 90)`, or cut
    /// conditions the force model rejects ([`BallEndForceModel::check_conditions`]; the depth is
    /// clamped to the ball, so only a bad speed or upfeed).
    pub fn static_deflection_um(&self, depth_cmd_um: f64) -> Result<f64, SimError> {
        let c = self
            .stiffness
            .z_compliance_um_per_n(self.program.tilt_deg)?;
        let mut delta = 0.0;
        for _ in 0..100 {
            let d = (depth_cmd_um - delta).clamp(0.0, self.force_model.tool.radius_um);
            let f = self.force_model.peak_z_force_n(&self.conditions(d))?;
            let next = f * c;
            if (next - delta).abs() < 1e-9 {
                return Ok(next);
            }
            delta = next;
        }
        Ok(delta)
    }
}

/// One step of the groove stage.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct GrooveStepOutput {
    /// Time since the start of the cut (s).
    pub t_s: f64,
    /// Tool position along the groove (mm).
    pub x_mm: f64,
    /// Programmed depth at x (µm).
    pub depth_cmd_um: f64,
    /// Depth actually cut at x (µm).
    pub depth_cut_um: f64,
    /// z-deflection of the tool from the force (µm, + = shallower).
    pub deflection_um: f64,
    /// PZT tool-tip (radial) displacement (µm).
    pub pzt_tip_um: f64,
    /// z-component of the PZT displacement from where the tool was touched off (µm, + = deeper; below
    /// 0 only after a touch-off at a bias, [`GrooveStage::touch_off_at`]).
    pub pzt_z_um: f64,
    /// Applied actuator voltage (V).
    pub applied_v: f64,
    /// True instantaneous workpiece z-force (N).
    pub force_z_n: f64,
    /// Measured force on the configured channel (N).
    pub force_meas_n: f64,
    /// Raw spindle y-force reading (N) incl. the PZT coupling.
    pub spindle_force_raw_n: f64,
    /// Capacitance-gauge reading of the tip displacement (µm).
    pub gauge_um: f64,
    /// Upfeed (µm/rev) actually run at this step (changes while the feed axis accelerates).
    pub upfeed_um: f64,
    /// Engagement of the tool with the material (1 inside the workpiece, falling to 0 at its exit edge;
    /// the groove bottom exists only where it is > 0).
    pub engagement: f64,
    /// True once x has reached the end of the groove.
    pub done: bool,
}

/// The steppable groove plant.
#[derive(Debug, Clone)]
pub struct GrooveStage {
    cfg: GrooveConfig,
    dt_s: f64,
    spindle: DiscretePztSpindle,
    force_sensor: ForceSensor,
    gauge: CapacitanceGauge,
    compliance_um_per_n: f64,
    sin_a: f64,
    cos_a: f64,
    omega_rad_s: f64,
    feed: FeedProfile,
    t_s: f64,
    deflection_um: f64,
    peak: SlidingMax,
    prepared: PreparedCut,
    prepared_depth: f64,
    prepared_upfeed: f64,
    last_tip_um: f64,
    /// The tip (µm) at which the tool was touched off: 0 for a touch-off at 0 V.
    tip_zero_um: f64,
}

impl GrooveStage {
    /// Build a stage stepping at `dt_s`.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] when [`GrooveConfig::validate`] fails, `dt_s` is not a finite
    /// positive number, or a noise sigma is negative or not finite; [`SimError::Numerical`] when
    /// the spindle's discretisation at `dt_s` is not finite.
    pub fn new(cfg: GrooveConfig, dt_s: f64) -> Result<Self, SimError> {
        cfg.validate()?;
        check_positive("dt_s", dt_s)?;
        let spindle = cfg.spindle.discretize(dt_s)?;
        let force_sensor = match cfg.force_noise {
            Some(n) => ForceSensor::new(n.sigma, 0.04, n.seed)?,
            None => ForceSensor::ideal(),
        };
        let gauge = match cfg.gauge_noise {
            Some(n) => CapacitanceGauge::new(50.0, 2.5, 0.0, n.sigma, n.seed)?,
            None => CapacitanceGauge::rd20(),
        };
        let p = &cfg.program;
        let compliance = cfg.stiffness.z_compliance_um_per_n(p.tilt_deg)?;
        let a = p.tilt_deg.to_radians();
        let steps_per_rev = (60.0 / p.speed_rpm / dt_s).round() as usize;
        let d0 = p.depth_at(0.0);
        let prepared = cfg.force_model.prepare(&cfg.conditions(d0));
        Ok(Self {
            dt_s,
            spindle,
            force_sensor,
            gauge,
            compliance_um_per_n: compliance,
            sin_a: a.sin(),
            cos_a: a.cos(),
            omega_rad_s: p.speed_rpm / 60.0 * 2.0 * PI,
            feed: cfg.feed_profile()?,
            t_s: 0.0,
            deflection_um: 0.0,
            peak: SlidingMax::new(steps_per_rev),
            prepared,
            prepared_depth: d0,
            prepared_upfeed: p.upfeed_um,
            last_tip_um: 0.0,
            tip_zero_um: 0.0,
            cfg,
        })
    }

    /// Touch the tool off with the stack held at `bias_v` (V) for `hold_s` (s) before the cut: the
    /// stack rises to the bias and settles there, and the depth's zero is the tip where it stands at the
    /// end of the hold, so the controllers can later retract the tip below it. Returns the mean gauge
    /// reading (µm) over the hold's last tenth — what the operator reads at the touch-off. Call before the
    /// first [`Self::step`]; the cut's time does not advance.
    ///
    /// # Errors
    /// [`SimError::InvalidParameter`] for a bias outside the amplifier's 0–`voltage_max_v` or a
    /// non-finite hold (a negative one holds for no time).
    pub fn touch_off_at(&mut self, bias_v: f64, hold_s: f64) -> Result<f64, SimError> {
        let v_max = self.cfg.spindle.voltage_max_v;
        if !(bias_v.is_finite() && (0.0..=v_max).contains(&bias_v)) {
            return Err(SimError::InvalidParameter {
                name: "touch_off_bias_v",
                value: bias_v,
                allowed: "within the amplifier's 0 V to voltage_max_v",
            });
        }
        check_finite("touch_off_hold_s", hold_s)?;
        let n = (hold_s.max(0.0) / self.dt_s).ceil() as usize;
        let tail = (n / 10).max(1);
        let (mut sum, mut k) = (0.0, 0usize);
        let mut tip = self.last_tip_um;
        for i in 0..n {
            tip = self.spindle.step(bias_v).tip_um;
            if i + tail >= n {
                sum += self.gauge.measure_um(tip) + self.cfg.instruments.gauge_offset_um;
                k += 1;
            }
        }
        self.last_tip_um = tip;
        self.tip_zero_um = tip;
        Ok(if k > 0 {
            sum / k as f64
        } else {
            self.cfg.instruments.gauge_offset_um
        })
    }

    /// Configuration.
    pub fn config(&self) -> &GrooveConfig {
        &self.cfg
    }

    /// Step size (s).
    pub fn dt_s(&self) -> f64 {
        self.dt_s
    }

    /// Current time (s).
    pub fn t_s(&self) -> f64 {
        self.t_s
    }

    /// z-compliance of the tilted tool (µm/N).
    pub fn z_compliance_um_per_n(&self) -> f64 {
        self.compliance_um_per_n
    }

    /// Tool-tip radial displacement per µm of wanted z-correction: `1/sin α` (eq. 26).
    pub fn tip_per_z(&self) -> f64 {
        if self.sin_a > 0.0 {
            1.0 / self.sin_a
        } else {
            f64::INFINITY
        }
    }

    /// The feed motion.
    pub fn feed_profile(&self) -> &FeedProfile {
        &self.feed
    }

    /// Whether the cut is finished.
    pub fn done(&self) -> bool {
        self.t_s >= self.feed.duration_s()
    }

    /// Advance one step with actuator command `command_v` (V; clamped to 0–1000 V, NaN holds).
    pub fn step(&mut self, command_v: f64) -> GrooveStepOutput {
        let SpindleStep {
            applied_v, tip_um, ..
        } = self.spindle.step(command_v);
        self.last_tip_um = tip_um;
        let x = self.feed.x_at(self.t_s);
        let upfeed = self.feed.upfeed_at(self.t_s);
        let engagement = self.cfg.engagement(x);
        let d_cmd = self.cfg.program.depth_at(x);
        let pzt_z = (tip_um - self.tip_zero_um) * self.sin_a;
        let d_cut = (d_cmd + self.cfg.instruments.touch_off_um - self.deflection_um
            + pzt_z
            + self.cfg.path_offset.at(x))
        .clamp(0.0, self.cfg.force_model.tool.radius_um);
        if (d_cut - self.prepared_depth).abs() > 1e-3
            || (upfeed - self.prepared_upfeed).abs() > 1e-4 * self.prepared_upfeed
        {
            self.prepared = self
                .cfg
                .force_model
                .prepare(&self.cfg.conditions_at(d_cut, upfeed));
            self.prepared_depth = d_cut;
            self.prepared_upfeed = upfeed;
        }
        let f = self.prepared.forces(self.omega_rad_s * self.t_s);
        let fz = f[2] * engagement;
        let peak = self.peak.step(fz);
        let deflection_now = self.deflection_um;
        self.deflection_um = peak * self.compliance_um_per_n;
        let coupling = self.cfg.spindle.force_coupling_n_per_um * tip_um;
        let spindle_raw_true = fz * self.cos_a / SPINDLE_Y_CALIBRATION + coupling;
        let instruments = self.cfg.instruments;
        let force_meas = match self.cfg.force_channel {
            ForceChannel::WorkpieceZ => self
                .force_sensor
                .measure(instruments.force_reading(fz, self.t_s)),
            ForceChannel::SpindleCalibrated => {
                let raw = self
                    .force_sensor
                    .measure(instruments.force_reading(spindle_raw_true, self.t_s));
                (raw - coupling) * SPINDLE_Y_CALIBRATION / self.cos_a
            }
        };
        let gauge = self.gauge.measure_um(tip_um) + instruments.gauge_offset_um;
        let out = GrooveStepOutput {
            t_s: self.t_s,
            x_mm: x,
            depth_cmd_um: d_cmd,
            depth_cut_um: d_cut,
            deflection_um: deflection_now,
            pzt_tip_um: tip_um,
            pzt_z_um: pzt_z,
            applied_v,
            force_z_n: fz,
            force_meas_n: force_meas,
            spindle_force_raw_n: spindle_raw_true,
            gauge_um: gauge,
            upfeed_um: upfeed,
            engagement,
            done: false,
        };
        self.t_s += self.dt_s;
        GrooveStepOutput {
            done: self.done(),
            ..out
        }
    }

    /// Run the whole cut with a command policy `policy(&last_output) -> volts` (first call gets `None`);
    /// returns every step.
    pub fn run(
        &mut self,
        mut policy: impl FnMut(Option<&GrooveStepOutput>) -> f64,
    ) -> Vec<GrooveStepOutput> {
        let n = (self.cfg.duration_s() / self.dt_s).ceil() as usize + 1;
        let mut out: Vec<GrooveStepOutput> = Vec::with_capacity(n);
        loop {
            let v = policy(out.last());
            let o = self.step(v);
            let done = o.done;
            out.push(o);
            if done {
                break;
            }
        }
        out
    }
}

/// A groove profile: depth cut vs x, sampled every `spacing_mm` from a run (nearest step at or after x).
pub fn profile(
    run: &[GrooveStepOutput],
    spacing_mm: f64,
) -> Result<Vec<(f64, f64, f64)>, SimError> {
    check_positive("spacing_mm", spacing_mm)?;
    let mut out = Vec::new();
    let mut next = 0.0;
    for o in run {
        if o.x_mm + 1e-12 >= next {
            out.push((o.x_mm, o.depth_cmd_um, o.depth_cut_um));
            next += spacing_mm;
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn depth_profiles() {
        let r = DepthProfile::Ramp {
            from_um: 0.0,
            to_um: 80.0,
        };
        assert_eq!(r.depth_at(10.0, 20.0), 40.0);
        let s = DepthProfile::Steps {
            steps: vec![(0.0, 10.0), (5.0, 20.0)],
        };
        assert_eq!(s.depth_at(4.9, 20.0), 10.0);
        assert_eq!(s.depth_at(5.0, 20.0), 20.0);
        assert!(
            DepthProfile::Constant { depth_um: 500.0 }
                .validate(400.0)
                .is_err()
        );
        let p = DepthProfile::Points {
            points: vec![(0.0, 40.0), (10.0, 40.0), (10.05, 60.0)],
        };
        assert_eq!(p.depth_at(5.0, 20.0), 40.0);
        assert!((p.depth_at(10.025, 20.0) - 50.0).abs() < 1e-9);
        assert_eq!(p.depth_at(15.0, 20.0), 60.0);
        assert_eq!(p.change_points_mm(), vec![10.0]);
        let bad = DepthProfile::Points {
            points: vec![(5.0, 40.0), (1.0, 40.0)],
        };
        assert!(
            bad.validate(400.0)
                .unwrap_err()
                .to_string()
                .contains("points.x_mm")
        );
    }

    fn run_uncompensated(cfg: GrooveConfig) -> Vec<GrooveStepOutput> {
        GrooveStage::new(cfg, 5e-5).unwrap().run(|_| 0.0)
    }

    #[test]
    fn feed_doubling_raises_the_deflection_and_shortens_the_cut() {
        let mut cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
        cfg.program.length_mm = 4.0;
        cfg.program.depth_profile = DepthProfile::Constant { depth_um: 40.0 };
        cfg.program.feed_changes = vec![FeedChange {
            x_mm: 2.0,
            upfeed_um: 20.0,
        }];
        let run = run_uncompensated(cfg.clone());
        let err_at = |x: f64| {
            run.iter()
                .find(|o| o.x_mm >= x)
                .map(|o| o.depth_cut_um - o.depth_cmd_um)
                .unwrap()
        };
        // a thicker chip pushes the tool further out of the cut (000 eq. 2: force grows with the chip)
        let (before, after) = (err_at(1.5), err_at(3.5));
        assert!(after < before - 0.5, "before {before}, after {after}");
        // 2 mm at 1.667 mm/s + 2 mm at 3.333 mm/s (+ the 17 ms acceleration) ≈ 1.8 s instead of 2.4 s
        let t_end = run.last().unwrap().t_s;
        assert!((t_end - 1.8).abs() < 0.02, "{t_end}");
        assert!((run.last().unwrap().upfeed_um - 20.0).abs() < 1e-9);
    }

    #[test]
    fn exit_unloads_the_tool() {
        let mut cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
        cfg.program.length_mm = 3.0;
        cfg.program.depth_profile = DepthProfile::Constant { depth_um: 60.0 };
        cfg.program.exit = Some(WorkpieceExit {
            x_mm: 2.5,
            length_mm: 0.2,
        });
        let run = run_uncompensated(cfg);
        let at = |x: f64| run.iter().find(|o| o.x_mm >= x).unwrap();
        assert!(at(2.0).deflection_um > 5.0);
        // past the edge nothing is cut: no force, the tool springs back
        let past = at(2.7);
        assert_eq!(past.engagement, 0.0);
        assert_eq!(past.force_z_n, 0.0);
        assert!(past.deflection_um.abs() < 1e-9);
        // halfway through the exit zone the peak force is about half
        let mid = at(2.4);
        assert!((mid.engagement - 0.5).abs() < 0.01);
    }

    /// Touched off with a hysteretic stack held at 300 V, the depth's zero is the tip there: holding the
    /// bias corrects nothing, and dropping to 0 V retracts the tip below the zero (the travel a touch-off
    /// at rest cannot have: at 0 V from rest the correction is exactly 0). The returned reading is the
    /// (ideal) gauge's at the end of the hold; a bias beyond the amplifier is refused by name.
    #[test]
    fn a_touch_off_at_a_bias_puts_the_depths_zero_at_the_biased_tip() {
        let mut cfg = GrooveConfig::thesis(20.0, 8.0).unwrap();
        cfg.program.depth_profile = DepthProfile::Constant { depth_um: 40.0 };
        cfg.spindle.hysteresis = Some(crate::actuator::BoucWenParams::DEFAULT);
        let mut rest = GrooveStage::new(cfg.clone(), 5e-5).unwrap();
        assert_eq!(rest.step(0.0).pzt_z_um, 0.0);
        let mut biased = GrooveStage::new(cfg, 5e-5).unwrap();
        let gauge = biased.touch_off_at(300.0, 0.2).unwrap();
        assert!(gauge > 5.0, "tip at 300 V {gauge}");
        assert!((gauge - biased.tip_zero_um).abs() < 1e-12);
        let held = biased.step(300.0).pzt_z_um;
        assert!(
            held.abs() < 0.01,
            "holding the bias moved the tip {held} µm in z"
        );
        let mut z = 0.0;
        for _ in 0..2000 {
            z = biased.step(0.0).pzt_z_um;
        }
        assert!(z < -0.3 * gauge * 20f64.to_radians().sin(), "z at 0 V {z}");
        match biased.touch_off_at(1200.0, 0.1) {
            Err(SimError::InvalidParameter { name, .. }) => assert_eq!(name, "touch_off_bias_v"),
            other => panic!("{other:?}"),
        }
    }
}

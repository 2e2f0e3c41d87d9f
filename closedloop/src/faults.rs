//! Fault injection: a scenario's `[[faults]]` applied to what the controllers measure (a force spike, a
//! stuck sensor) and to the MPC's solver (failures from a time on). The plant itself is never touched.

use millcomp_mpc::groove::GrooveMeasurement;
use millcomp_mpc::thin_wall::ThinWallMeasurement;
use millcomp_sim::groove::GrooveStepOutput;
use millcomp_sim::thinwall::ThinWallStepOutput;

use crate::scenario::{Fault, Scenario};

/// What the groove controllers measure after stage step `o`, with the faults active at its time:
/// spikes add to the force; a stuck sensor freezes force and gauge at their last good values
/// (`stuck` carries them from step to step).
pub fn groove_measurement(
    o: &GrooveStepOutput,
    faults: &[Fault],
    stuck: &mut Option<(f64, f64)>,
) -> GrooveMeasurement {
    let mut m = GrooveMeasurement {
        force_meas_n: o.force_meas_n,
        gauge_um: o.gauge_um,
    };
    let t = o.t_s;
    let mut stuck_now = false;
    for f in faults {
        match *f {
            Fault::ForceSpike {
                t_s,
                magnitude_n,
                duration_s,
            } if t >= t_s && t < t_s + duration_s => {
                m.force_meas_n += magnitude_n;
            }
            Fault::StuckSensor { t_s, duration_s } if t >= t_s && t < t_s + duration_s => {
                stuck_now = true
            }
            _ => {}
        }
    }
    if stuck_now {
        let (f, g) = *stuck.get_or_insert((m.force_meas_n, m.gauge_um));
        m.force_meas_n = f;
        m.gauge_um = g;
    } else {
        // keep the last good value as the candidate to freeze at
        *stuck = Some((m.force_meas_n, m.gauge_um));
    }
    m
}

/// What the thin-wall controllers measure after stage step `o` (of length `dt_s`), with the faults
/// active at its time applied to the force channel (a fault lasts at least one step); the stage
/// position (grating ruler) is not affected.
pub fn thin_wall_measurement(
    o: &ThinWallStepOutput,
    faults: &[Fault],
    dt_s: f64,
    stuck: &mut Option<f64>,
) -> ThinWallMeasurement {
    let mut f = o.force_meas_n;
    let mut stuck_now = false;
    for fault in faults {
        match *fault {
            Fault::ForceSpike {
                t_s,
                magnitude_n,
                duration_s,
            } if o.t_s >= t_s && o.t_s < t_s + duration_s.max(dt_s) => f += magnitude_n,
            Fault::StuckSensor { t_s, duration_s }
                if o.t_s >= t_s && o.t_s < t_s + duration_s.max(dt_s) =>
            {
                stuck_now = true
            }
            _ => {}
        }
    }
    if stuck_now {
        f = *stuck.get_or_insert(f);
    } else {
        *stuck = Some(f);
    }
    ThinWallMeasurement {
        force_meas_n: f,
        encoder_um: o.encoder_um,
    }
}

/// The injected solver failures still to come, `(t_s, cycles)` in file order.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct SolverFailures {
    pending: Vec<(f64, usize)>,
}

impl SolverFailures {
    /// The scenario's `solver_failure` faults ([`Scenario::solver_failures`]).
    pub fn new(s: &Scenario) -> Self {
        Self {
            pending: s.solver_failures(),
        }
    }

    /// Hand every failure due at `t_s` to `inject` (its number of cycles) and forget it.
    pub fn inject_due(&mut self, t_s: f64, mut inject: impl FnMut(usize)) {
        self.pending.retain(|&(t, n)| {
            if t_s >= t {
                inject(n);
                false
            } else {
                true
            }
        });
    }
}

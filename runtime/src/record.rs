//! A simulated machine's run recorded as a machine's control task would record it: the program's
//! controller drives sim's groove stage, and every cycle's measurement (what the controller read) and
//! command (what it sent) are kept — the sensor log `millcomp replay` takes (`millcomp simulate
//! PROGRAM --bundle B --sensor-log LOG`, docs/replay.md).
//!
//! The machine is sim's published S7 groove stage ([`GrooveConfig::thesis`]) cutting the program's NC
//! program, with the force sensor's and the gauge's noise; the controller knows only its bundle and
//! program, as on a real machine.

use millcomp_sim::groove::{GrooveConfig, GrooveStage};
use millcomp_sim::sensors::NoiseSpec;

use crate::controller::{Command, Controller, Measurement};
use crate::error::RuntimeError;
use crate::program::Program;

/// The simulated machine a run is recorded on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SimulatedMachine {
    /// The tool's wearland (µm; the published simulation's 8 µm by default).
    pub wearland_um: f64,
    /// The force sensor's noise (σ in N, its seed), or none.
    pub force_noise: Option<NoiseSpec>,
    /// The gauge's noise (σ in µm, its seed), or none.
    pub gauge_noise: Option<NoiseSpec>,
}

impl Default for SimulatedMachine {
    /// The published simulation's tool (8 µm wearland) with the thesis' sensor noise levels (force σ
    /// 0.04 N, gauge σ 0.01 µm), seeds 7 and 8.
    fn default() -> Self {
        Self::with_seed(7)
    }
}

impl SimulatedMachine {
    /// [`Self::default`] with the force noise seeded `seed` and the gauge's `seed + 1`.
    pub fn with_seed(seed: u64) -> Self {
        Self {
            wearland_um: 8.0,
            force_noise: Some(NoiseSpec { seed, sigma: 0.04 }),
            gauge_noise: Some(NoiseSpec {
                seed: seed.wrapping_add(1),
                sigma: 0.01,
            }),
        }
    }
}

/// A recorded run: row `k` of [`Self::log`] is what the controller read at the start of cycle `k`
/// (the readings sampled at the end of cycle `k − 1`; the first row: no reading yet, all NaN), and
/// [`Self::commands`]`[k]` what it sent.
#[derive(Debug, Clone, PartialEq)]
pub struct Recording {
    /// The controller's period (s): row `k` is at `k · period_s`.
    pub period_s: f64,
    /// The measurements, one per cycle.
    pub log: Vec<Measurement>,
    /// The commands, one per cycle.
    pub commands: Vec<Command>,
}

/// `steps` cycles of `controller` (built from `program`) on the simulated `machine` cutting the
/// program, from the controller's current state.
///
/// # Examples
/// ```
/// use millcomp_runtime::record::{SimulatedMachine, record};
/// use millcomp_runtime::{Controller, Program, replay::replay};
/// # let dir = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/");
/// # let bundle = std::path::PathBuf::from(format!("{dir}bundle_s7.toml"));
/// # let program_path = std::path::PathBuf::from(format!("{dir}ramp_20deg.toml"));
/// let program = Program::load(&program_path).unwrap();
/// let mut ctl = Controller::from_files(&bundle, &program_path).unwrap();
/// let run = record(&mut ctl, &program, &SimulatedMachine::default(), 600).unwrap();
/// assert!(run.log[0].force_n.is_nan() && run.log[1].force_n.is_finite());
/// // the log through a fresh controller: the commands sent while it was recorded, bit for bit
/// ctl.reset().unwrap();
/// assert_eq!(replay(&mut ctl, &run.log).commands, run.commands);
/// ```
///
/// # Errors
/// [`RuntimeError::Simulation`] when sim refuses the machine or the program.
pub fn record(
    controller: &mut Controller,
    program: &Program,
    machine: &SimulatedMachine,
    steps: usize,
) -> Result<Recording, RuntimeError> {
    let sim = |source| RuntimeError::Simulation {
        source: Box::new(source),
    };
    let mut truth =
        GrooveConfig::thesis(program.program.tilt_deg, machine.wearland_um).map_err(sim)?;
    truth.program = program.program.groove_program();
    truth.force_noise = machine.force_noise;
    truth.gauge_noise = machine.gauge_noise;
    let period_s = controller.period_s();
    let mut stage = GrooveStage::new(truth, period_s).map_err(sim)?;
    let mut log = Vec::with_capacity(steps);
    let mut commands = Vec::with_capacity(steps);
    let mut m = Measurement::NONE;
    for _ in 0..steps {
        log.push(m);
        let c = controller.step(&m);
        commands.push(c);
        let o = stage.step(c.voltage_v);
        m = Measurement {
            x_mm: o.x_mm,
            force_n: o.force_meas_n,
            gauge_um: o.gauge_um,
        };
    }
    Ok(Recording {
        period_s,
        log,
        commands,
    })
}

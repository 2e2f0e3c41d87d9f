//! The harnesses of millcomp's fuzz targets: one function per reader of user input, taking the raw
//! bytes a user could hand it. Each runs the reader the way the CLI does and checks what must hold
//! whatever the input: no panic, and where a reader accepts, what it promises (a validated numeric
//! column holds only finite numbers, columns have equal lengths, …).
//!
//! The same file is compiled twice: by cargo-fuzz as the library of `fuzz/` (nightly, libFuzzer), and
//! by stable `cargo test` as a module of closedloop's integration tests
//! (`closedloop/tests/fuzz_regressions.rs`), which replays every input kept under
//! `fuzz/regressions/<target>/`. So it names no `crate::` path and uses only crates both see.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use millcomp_closedloop::Scenario;
use millcomp_closedloop::batch::plan::Plan;
use millcomp_datasets::mapping::{ColumnMap, map_table};
use millcomp_datasets::{
    ColumnData, ColumnKind, ColumnSpec, Schema, Table, contracts, read_any, read_any_str,
    read_table,
};
use millcomp_doe::{
    CcdAlpha, CcdVariant, DesignKind, DesignRequest, FactorSpec, LinearConstraint, ModelSpec,
    Values,
};
use millcomp_models::{
    ForceModelParams, HysteresisModel, IdentifiedModel, ModelBundle, ModelFile, ResponseSurface,
    SensorNoise, SpindleModel, StiffnessModel,
};
use millcomp_mpc::identified::{
    IdentifiedForceModel, IdentifiedHysteresis, IdentifiedSpindle, IdentifiedStiffness, NominalTool,
};
use millcomp_mpc::replay::{QpSequence, replay_clarabel};
use millcomp_runtime::replay::{measurements, replay};
use millcomp_runtime::{Controller, ControllerKind, Origins, Program, flags};
use millcomp_sim::session::Session;

/// The fuzz targets, by name (`fuzz/fuzz_targets/<name>.rs`, `fuzz/regressions/<name>/`).
pub const TARGETS: [&str; 10] = [
    "table",
    "scenario",
    "batch_plan",
    "model_file",
    "session",
    "column_map",
    "doe_spec",
    "qp_sequence",
    "sensor_log",
    "program",
];

/// Runs the harness of target `name` on `data` (what the regression test calls).
///
/// # Panics
/// On an unknown target, and wherever the harness panics.
pub fn run(name: &str, data: &[u8]) {
    match name {
        "table" => table(data),
        "scenario" => scenario(data),
        "batch_plan" => batch_plan(data),
        "model_file" => model_file(data),
        "session" => session(data),
        "column_map" => column_map(data),
        "doe_spec" => doe_spec(data),
        "qp_sequence" => qp_sequence(data),
        "sensor_log" => sensor_log(data),
        "program" => program(data),
        other => panic!("no fuzz target `{other}`"),
    }
}

/// Called by every fuzz target before each input; once per process it replaces libFuzzer's panic
/// hook (print, then abort — before any `catch_unwind` can act) by one that only prints. A panic a
/// reader catches at its boundary and reports as an error (the table reader around polars) is then
/// not a crash; a panic nobody catches still is: `fuzz_target!` catches it and aborts.
pub fn init() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        std::panic::set_hook(Box::new(|info| eprintln!("panic: {info}")));
    });
}

/// A directory for the files a harness writes (readers that take a path), one per process.
fn scratch() -> &'static Path {
    static DIR: OnceLock<tempfile::TempDir> = OnceLock::new();
    DIR.get_or_init(|| {
        tempfile::Builder::new()
            .prefix("millcomp-fuzz-")
            .tempdir()
            .expect("a temporary directory")
    })
    .path()
}

fn scratch_file(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch().join(name);
    std::fs::write(&path, bytes).expect("writing the scratch file");
    path
}

/// Checks what an accepted table promises: equal column lengths, finite floats, the schema's
/// required columns present with their kind.
fn check_table(t: &Table, schema: Option<&Schema>) {
    let n = t.n_rows();
    for c in &t.columns {
        assert_eq!(c.data.len(), n, "column `{}` of {}", c.name, t.origin);
        if let ColumnData::Float(v) = &c.data {
            assert!(
                v.iter().all(|x| x.is_finite()),
                "column `{}` of {} holds a non-finite number",
                c.name,
                t.origin
            );
        }
    }
    if let Some(s) = schema {
        assert!(n > 0, "{} accepted without rows", t.origin);
        for spec in s.columns.iter().filter(|c| c.required) {
            let c = t
                .column(&spec.name)
                .unwrap_or_else(|| panic!("{}: required `{}` missing", t.origin, spec.name));
            let ok = matches!(
                (&c.data, spec.kind),
                (ColumnData::Float(_), ColumnKind::Float)
                    | (ColumnData::Int(_), ColumnKind::Int | ColumnKind::Flag)
                    | (ColumnData::Text(_), ColumnKind::Text)
            );
            assert!(ok, "{}: `{}` has the wrong kind", t.origin, spec.name);
            if spec.kind == ColumnKind::Flag {
                assert!(
                    t.i64s(&spec.name)
                        .unwrap()
                        .iter()
                        .all(|f| *f == 0 || *f == 1),
                    "{}: flag `{}` not 0/1",
                    t.origin,
                    spec.name
                );
            }
        }
    }
}

/// A schema of every kind, for the generic reader.
fn every_kind_schema() -> Schema {
    Schema::new(
        "fuzz",
        vec![
            ColumnSpec::required("x_um", ColumnKind::Float, "a number"),
            ColumnSpec::optional("n", ColumnKind::Int, "an integer"),
            ColumnSpec::optional("on", ColumnKind::Flag, "a flag"),
            ColumnSpec::optional("note", ColumnKind::Text, "text"),
        ],
    )
}

/// The table reader (`datasets/src/table.rs`) on a file of these bytes. The first byte chooses the
/// file's extension (`.csv` or `.parquet`); the rest is the file. Every reader of a table file runs on
/// it: without a schema ([`read_any`]), with a schema of every column kind, and the measured-groove and
/// force-trace contracts.
pub fn table(data: &[u8]) {
    let Some((&mode, body)) = data.split_first() else {
        return;
    };
    let name = if mode & 1 == 0 { "t.csv" } else { "t.parquet" };
    let path = scratch_file(name, body);
    if let Ok(t) = read_any(&path) {
        check_table(&t, None);
    }
    let schema = every_kind_schema();
    if let Ok(t) = read_table(&path, &schema) {
        check_table(&t, Some(&schema));
    }
    if let Ok(g) = contracts::read_measured_groove(&path) {
        assert!(
            g.points
                .iter()
                .all(|p| p.depth_meas_um.is_finite() && p.t_s.is_finite()),
            "a measured groove with a non-finite depth or time"
        );
    }
    if let Ok(f) = contracts::read_force_trace(&path) {
        assert!(f.iter().all(|p| p.x_mm.is_finite()));
    }
}

/// A scenario file (`closedloop/src/scenario.rs`): parse and validate, as `simulate` does before it
/// builds anything.
pub fn scenario(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    if let Ok(s) = Scenario::from_toml_str(text, "fuzz.toml") {
        let _ = s.control.cycle_budget();
        let _ = s.solver_failures();
    }
}

/// A batch plan table (`closedloop/src/batch/factors.rs`): CSV text read as `batch --scenarios` reads
/// it, every scenario built once, with the default controllers.
pub fn batch_plan(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(table) = read_any_str("plan.csv", text) else {
        return;
    };
    if let Ok(plan) = Plan::from_table(&table, vec!["pid".into(), "mpc".into()]) {
        assert_eq!(plan.n_runs(), 2 * table.n_rows());
    }
}

/// A model file (`models/`): the text is read as each kind a consumer reads (spindle, force,
/// stiffness, hysteresis, sensor noise, response surface, bundle), then handed to the views and
/// the controllers' constructors a scenario would build from it.
pub fn model_file(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let at = Path::new("fuzz-model.toml");
    if let Ok(f) = ModelFile::<IdentifiedModel>::from_toml(text, at, &[]) {
        let m = &f.model;
        if let Ok(s) = SpindleModel::from_identified(m, at) {
            let _ = IdentifiedSpindle::new(&s);
        }
        if let Ok(p) = ForceModelParams::from_identified(m, at) {
            if let Ok(fm) = IdentifiedForceModel::new(&p, &NominalTool::thesis_ball_end("S7")) {
                let _ = fm.perturbed(&[("w_mpa", 0.05)]);
            }
        }
        if let Ok(k) = StiffnessModel::from_identified(m, at) {
            let _ = IdentifiedStiffness::new(&k);
        }
        if let Ok(h) = HysteresisModel::from_identified(m, at) {
            let _ = IdentifiedHysteresis::new(&h);
        }
        let _ = SensorNoise::from_identified(m, at);
        let _ = SensorNoise::from_residuals(m, m, at);
    }
    if let Ok(f) = ModelFile::<ResponseSurface>::from_toml(text, at, &ResponseSurface::KINDS) {
        let point: Vec<(&str, f64)> = Vec::new();
        let _ = f.model.predict(&point);
        let _ = millcomp_mpc::predictor::ResponseSurface::new(f.model, "fuzz-model.toml");
    }
    if let Ok(f) = ModelFile::<ModelBundle>::from_toml(text, at, &ModelBundle::KINDS) {
        let b = f.model;
        let _ = b.check_material("S7", at);
        if let Ok(s) = b.spindle(at, "fuzz") {
            let _ = IdentifiedSpindle::new(&s);
        }
        if let Ok(p) = b.force(at, "fuzz") {
            let _ = IdentifiedForceModel::new(&p, &NominalTool::thesis_ball_end(&b.material));
        }
        if let Ok(k) = b.stiffness(at, "fuzz") {
            let _ = IdentifiedStiffness::new(&k);
        }
        if let Ok(Some(h)) = b.hysteresis(at) {
            let _ = IdentifiedHysteresis::new(&h);
        }
        let _ = b.sensor_noise(at, "fuzz");
    }
}

/// A diagnose session file (`sim/src/session.rs`): parse, validate and play the plan out as
/// `diagnose` and `simulate` do before comparing (material, force model, stiffness, effects, the
/// nominal context of every measured point).
pub fn session(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(s) = Session::from_toml_str(text) else {
        return;
    };
    let _ = s.material();
    let _ = s.force_model();
    let _ = s.stiffness();
    let _ = s.effects();
    let _ = s.timeline();
    let _ = s.contexts();
}

/// The record mapping (`--columns`, `datasets/src/mapping.rs`): the first line is the mapping, the
/// rest a CSV file read through it, without a schema (as `diagnose --record` and `identify` read) and
/// against the measured-groove contract (as `diagnose SESSION MEASURED --columns` reads).
pub fn column_map(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let (spec, csv) = text.split_once('\n').unwrap_or((text, ""));
    let Ok(map) = ColumnMap::parse(spec) else {
        return;
    };
    if let Ok(t) = read_any_str("record.csv", csv) {
        if let Ok(m) = map_table(t, &map) {
            check_table(&m.table, None);
            for g in &m.groups {
                for c in &g.columns {
                    assert!(
                        m.table.column(c).is_some(),
                        "role `{}`: column `{c}` not in the mapped table",
                        g.role
                    );
                }
            }
        }
    }
    let path = scratch_file("mapped.csv", csv.as_bytes());
    if let Ok((t, _)) = contracts::read_measured_groove_table_mapped(&path, &map) {
        check_table(&t, None);
    }
}

/// Sizes a design may take in this target, so that the fuzzer explores the parsers and builders
/// rather than waiting on a legitimately big design (bounds of the request itself are the library's;
/// these only cap what the harness asks for).
const MAX_RUNS: usize = 256;
const MAX_REPLICATES: usize = 4;
const MAX_CENTER: usize = 8;
const MAX_BLOCKS: usize = 16;

/// The `doe design` specifications (`doe/src/factor.rs`, `design/`, `model.rs`): one argument per
/// line — design, factors, resolution, generators, runs, replicates, centre points, blocks, CCD
/// variant, alpha, model, constraints (a missing line is the default) — parsed as the CLI does
/// (`src/cmd/doe.rs: design_request`), then the design generated and its columns taken.
pub fn doe_spec(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let mut lines = text.split('\n');
    let mut next = || lines.next().map(str::trim).filter(|s| !s.is_empty());
    let design = next().unwrap_or("full");
    let factors = next().unwrap_or("A,B");
    let resolution = next().and_then(|s| s.parse::<u32>().ok());
    let generators = next().map(str::to_string);
    let runs = next().and_then(|s| s.parse::<usize>().ok());
    let replicates = next().and_then(|s| s.parse::<usize>().ok()).unwrap_or(1);
    let center = next().and_then(|s| s.parse::<usize>().ok());
    let blocks = next().and_then(|s| s.parse::<usize>().ok()).unwrap_or(1);
    let variant = next().unwrap_or("circumscribed");
    let alpha = next().unwrap_or("rotatable");
    let model = next();
    let constraints = next();

    let Ok(factors) = FactorSpec::parse_list(factors) else {
        return;
    };
    let Ok(mut kind) = design.parse::<DesignKind>() else {
        return;
    };
    if let DesignKind::Ccd {
        variant: v,
        alpha: a,
    } = &mut kind
    {
        if design == "ccd" {
            let Ok(parsed) = variant.parse::<CcdVariant>() else {
                return;
            };
            *v = parsed;
        }
        let Ok(parsed) = alpha.parse::<CcdAlpha>() else {
            return;
        };
        *a = parsed;
    }
    let mut req = DesignRequest::new(kind, factors);
    req.resolution = resolution;
    req.generators = generators;
    req.runs = runs.map(|r| r.min(MAX_RUNS));
    req.replicates = replicates.min(MAX_REPLICATES);
    req.center_points = center.map(|c| c.min(MAX_CENTER));
    req.blocks = blocks.min(MAX_BLOCKS);
    req.seed = Some(1);
    if let Some(m) = model {
        let Ok(m) = ModelSpec::parse(m) else {
            return;
        };
        req.model = Some(m);
    }
    if let Some(c) = constraints {
        let Ok(c) = LinearConstraint::parse_list(c, &req.factors) else {
            return;
        };
        req.constraints = c;
    }
    if let Ok(d) = millcomp_doe::generate(&req) {
        let n = d.n_runs();
        for (name, col) in d.columns() {
            let len = match &col {
                Values::F64(v) => v.len(),
                Values::I64(v) => v.len(),
                Values::Str(v) => v.len(),
            };
            assert_eq!(len, n, "design column `{name}`");
        }
        for r in &d.runs {
            assert!(
                r.coded.iter().all(|c| c.is_finite()),
                "a non-finite coded level"
            );
        }
    }
}

/// A recorded QP sequence (`mpc/src/replay.rs`): JSON as `qp_replay replay` reads it, then replayed
/// with Clarabel.
pub fn qp_sequence(data: &[u8]) {
    let Ok(seq) = serde_json::from_slice::<QpSequence>(data) else {
        return;
    };
    let _ = replay_clarabel(&seq);
}

/// The bundle and program `sensor_log` replays an accepted log with (the shipped ones of
/// `runtime/tests/data/`, which docs/replay.md's example uses); compiled in, so that the harness
/// reads them from no path of its own.
const REPLAY_BUNDLE: &str = include_str!("../../runtime/tests/data/bundle_s7.toml");
const REPLAY_PROGRAM: &str = include_str!("../../runtime/tests/data/ramp_20deg.toml");

/// The amplifier's maximum of the shipped bundle's spindle (`sim/src/spindle.rs`: 1000 V, the
/// thesis' §5.2.2); a command is within 0 ..= this (`millcomp_runtime::Command::voltage_v`).
const VOLTAGE_MAX_V: f64 = 1000.0;

/// Where the shipped bundle and program are (named in errors).
fn replay_origins() -> Origins {
    Origins {
        bundle: PathBuf::from("runtime/tests/data/bundle_s7.toml"),
        program: PathBuf::from("runtime/tests/data/ramp_20deg.toml"),
    }
}

/// The shipped bundle, read once per process.
fn replay_bundle() -> &'static ModelBundle {
    static BUNDLE: OnceLock<ModelBundle> = OnceLock::new();
    BUNDLE.get_or_init(|| {
        ModelFile::<ModelBundle>::from_toml(
            REPLAY_BUNDLE,
            &replay_origins().bundle,
            &ModelBundle::KINDS,
        )
        .expect("the shipped bundle")
        .model
    })
}

/// The program and one controller of every kind the shipped bundle builds, built once per process
/// (building plans the whole program); each input replays from a [`Controller::reset`], which gives
/// the same commands as a new controller, bit for bit.
fn replay_controllers() -> &'static std::sync::Mutex<(Program, Vec<Controller>)> {
    static CTLS: OnceLock<std::sync::Mutex<(Program, Vec<Controller>)>> = OnceLock::new();
    CTLS.get_or_init(|| {
        let origins = replay_origins();
        let program =
            Program::from_toml_str(REPLAY_PROGRAM, &origins.program).expect("the shipped program");
        let ctls: Vec<Controller> = ControllerKind::ALL
            .iter()
            .filter_map(|&kind| {
                let mut p = program.clone();
                p.controller.kind = kind;
                Controller::from_bundle_at(replay_bundle(), &p, &origins).ok()
            })
            .collect();
        std::sync::Mutex::new((program, ctls))
    })
}

/// Checks `commands` of `who` are what a controller promises: each finite and within 0 ..= the
/// amplifier's maximum, never the "command held" of a non-finite command.
fn check_commands(who: &str, commands: &[millcomp_runtime::Command]) {
    for (k, c) in commands.iter().enumerate() {
        assert!(
            c.voltage_v.is_finite() && (0.0..=VOLTAGE_MAX_V).contains(&c.voltage_v),
            "{who}: cycle {k} sends {} V",
            c.voltage_v
        );
        assert!(
            !c.has(flags::COMMAND_HELD),
            "{who}: cycle {k} computed a non-finite command (held)"
        );
    }
}

/// Kinds of controller `sensor_log` replays with (those the shipped bundle builds).
pub fn replay_kinds() -> Vec<ControllerKind> {
    let guard = replay_controllers()
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    guard.1.iter().map(Controller::kind).collect()
}

/// The sensor log (`datasets::contracts::read_sensor_log`), read as `millcomp replay BUNDLE PROGRAM
/// LOG` reads it: the first byte chooses the file's extension (`.csv` or `.parquet`), the rest is the
/// file. An accepted log must hold what the contract promises (columns of one length, finite times,
/// readings finite or NaN, never infinite) and write and read back the same (the writer of `simulate
/// --sensor-log`); a log at the shipped program's rate (`SensorLog::check_rate`, the replay's next
/// check) is then replayed through every controller the shipped bundle builds, as `replay
/// --controllers` does: each command finite and within 0 ..= the amplifier's maximum, never the
/// "command held" of a non-finite command, one per sample.
pub fn sensor_log(data: &[u8]) {
    let Some((&mode, body)) = data.split_first() else {
        return;
    };
    let ext = if mode & 1 == 0 { "csv" } else { "parquet" };
    let path = scratch_file(&format!("log.{ext}"), body);
    let Ok(log) = contracts::read_sensor_log(&path) else {
        return;
    };
    let origin = path.display().to_string();
    let n = log.len();
    assert!(n > 0, "{origin}: a log without samples accepted");
    for (name, col) in [
        ("x_mm", &log.x_mm),
        ("force_n", &log.force_n),
        ("gauge_um", &log.gauge_um),
    ] {
        assert_eq!(col.len(), n, "{origin}: `{name}` of another length");
        assert!(
            col.iter().all(|x| !x.is_infinite()),
            "{origin}: an infinite `{name}` accepted"
        );
    }
    assert!(
        log.t_s.iter().all(|t| t.is_finite()),
        "{origin}: a non-finite `t_s` accepted"
    );

    // written as `simulate --sensor-log` writes it, read back the same (NaN as NaN)
    let back = scratch().join(format!("back.{ext}"));
    let table = contracts::sensor_log_table(&origin, &log).expect("the table of an accepted log");
    millcomp_datasets::write_table(&table, &back).expect("writing an accepted log");
    let again = contracts::read_sensor_log(&back)
        .unwrap_or_else(|e| panic!("{origin}: the log as written is refused: {e}"));
    let same = |a: &[f64], b: &[f64]| {
        a.len() == b.len()
            && a.iter()
                .zip(b)
                .all(|(x, y)| x.to_bits() == y.to_bits() || (x.is_nan() && y.is_nan()))
    };
    assert!(
        same(&log.t_s, &again.t_s)
            && same(&log.x_mm, &again.x_mm)
            && same(&log.force_n, &again.force_n)
            && same(&log.gauge_um, &again.gauge_um),
        "{origin}: the log does not read back the same after being written"
    );

    let mut guard = replay_controllers()
        .lock()
        .unwrap_or_else(|e| e.into_inner());
    let (program, ctls) = &mut *guard;
    if log.check_rate(&origin, program.controller.dt_s).is_err() {
        return;
    }
    let m = measurements(&log.x_mm, &log.force_n, &log.gauge_um);
    for ctl in ctls.iter_mut() {
        ctl.reset().expect("resetting a controller");
        let r = replay(ctl, &m);
        let who = ctl.kind().name();
        assert_eq!(r.commands.len(), n, "{who}: a command per sample");
        check_commands(who, &r.commands);
    }
}

/// The longest cut (s) `program` builds a controller for: building plans the whole program, in time
/// linear in its length, so that the fuzzer explores the reader and the builders rather than waiting
/// on a legitimately long groove (the shipped 20° groove is 12 s; this only caps what the harness
/// builds, not what the reader accepts).
const MAX_PROGRAM_S: f64 = 30.0;

/// Cycles `program` steps a built controller through.
const PROGRAM_STEPS: usize = 40;

/// A program file (`millcomp_runtime::Program`: `millcomp replay BUNDLE PROGRAM LOG`, `simulate
/// PROGRAM --bundle`, the Python `Controller` and the C ABI), read and validated as they read it. An
/// accepted program writes back (`Program::to_toml`) and reads back the same; a program of at most
/// [`MAX_PROGRAM_S`] of cut then builds its controller from the shipped bundle (or is refused with an
/// error), which is stepped through [`PROGRAM_STEPS`] cycles of readings (none yet, then a constant
/// force and gauge reading, a missed sample, an NC position off the program): each command finite and
/// within 0 ..= the amplifier's maximum, never the "command held" of a non-finite command.
pub fn program(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let at = Path::new("fuzz-program.toml");
    let Ok(p) = Program::from_toml_str(text, at) else {
        return;
    };
    let written = p
        .to_toml()
        .unwrap_or_else(|e| panic!("an accepted program does not write: {e}"));
    let again = Program::from_toml_str(&written, at)
        .unwrap_or_else(|e| panic!("an accepted program as written is refused: {e}\n{written}"));
    assert_eq!(
        again, p,
        "the program does not read back the same\n{written}"
    );

    let duration_s = p.program.groove_program().duration_s();
    if duration_s.is_nan() || duration_s > MAX_PROGRAM_S {
        return;
    }
    let origins = Origins {
        bundle: replay_origins().bundle,
        program: at.to_path_buf(),
    };
    let Ok(mut ctl) = Controller::from_bundle_at(replay_bundle(), &p, &origins) else {
        return;
    };
    let log: Vec<millcomp_runtime::Measurement> = (0..PROGRAM_STEPS)
        .map(|k| {
            let t_s = k as f64 * p.controller.dt_s;
            millcomp_runtime::Measurement {
                x_mm: if k == 25 { 1e3 } else { t_s * 1e-3 },
                force_n: if k == 0 || k == 20 { f64::NAN } else { 0.5 },
                gauge_um: if k == 0 { f64::NAN } else { 1.0 },
            }
        })
        .collect();
    let r = replay(&mut ctl, &log);
    assert_eq!(r.commands.len(), PROGRAM_STEPS);
    check_commands(ctl.kind().name(), &r.commands);
}

//! Commission once: a commissioned bundle is a function of what the commissioning sees — the truth's
//! force model, stiffness and spindle, the program's speed and tilt, the instruments and the sensors'
//! noise, the material, the commissioning plan and the seed — so it is computed once per distinct
//! *commissioning key* ([`CommissioningKey`]) and kept in a content-addressed cache on disk: the file
//! `DIR/commissioning/<SHA-256 of the key>.toml` is the bundle in the common model-file format (kind
//! `bundle`). Processes that share the directory (the slices of a batch on a cluster) share the bundles;
//! two that compute the same key at once write the same model (the later rename wins). Within a
//! process a key is computed by one thread while the others that need it wait for it.
//!
//! The commissioning is handed the truth with everything outside the key reset
//! ([`CommissioningKey::new`]), so what it computes cannot depend on anything the key leaves out:
//! a cached bundle is the bundle a fresh commissioning would give, value for value.

use std::collections::{HashMap, VecDeque};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, OnceLock};

use millcomp_models::{ModelBundle, ModelFile, Provenance, sha256_hex};
use millcomp_sim::groove::{ForceChannel, GrooveConfig, GrooveProgram};
use millcomp_sim::sensors::InstrumentErrors;
use serde::{Deserialize, Serialize};

use crate::commissioning::{CommissioningPlant, commission_bundle};
use crate::commissioning_plan::CommissioningPlan;
use crate::error::ClosedLoopError;
use crate::profile::{Stage, timed};

/// Format tag of a key (hashed with it: a change of what the key holds changes every address).
pub const KEY_FORMAT: &str = "millcomp-commissioning-key/1";

/// Everything a commissioning's bundle depends on.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CommissioningKey {
    /// [`KEY_FORMAT`].
    pub format: String,
    /// The program's version: a new version may commission differently.
    pub version: String,
    /// The truth as the commissioning sees it: force model, stiffness, spindle, the program's speed
    /// and tilt (the rest of the program, the force channel, the noise specs and the instruments reset
    /// to the thesis' defaults — the instruments and noise levels are below).
    pub truth: GrooveConfig,
    /// The instruments' errors.
    pub instruments: InstrumentErrors,
    /// Force-sensor noise σ (N).
    pub force_noise_n: f64,
    /// Gauge noise σ (µm).
    pub gauge_noise_um: f64,
    /// The workpiece material (the nominal model's).
    pub material: String,
    /// The experiments.
    pub plan: CommissioningPlan,
    /// Seed of the experiments' noise.
    pub seed: u64,
}

impl CommissioningKey {
    /// The key of commissioning `plant` with `plan` and `seed`.
    pub fn new(plant: &CommissioningPlant<'_>, plan: &CommissioningPlan, seed: u64) -> Self {
        let t = plant.truth;
        let mut program = GrooveProgram::thesis(t.program.tilt_deg);
        program.speed_rpm = t.program.speed_rpm;
        Self {
            format: KEY_FORMAT.to_string(),
            version: env!("CARGO_PKG_VERSION").to_string(),
            truth: GrooveConfig {
                force_model: t.force_model.clone(),
                stiffness: t.stiffness,
                spindle: t.spindle.clone(),
                program,
                force_channel: ForceChannel::default(),
                force_noise: None,
                gauge_noise: None,
                instruments: InstrumentErrors::default(),
                // the calibrations cut no groove: the path's offset is not the commissioning's
                path_offset: Default::default(),
            },
            instruments: plant.instruments,
            force_noise_n: plant.force_noise_n,
            gauge_noise_um: plant.gauge_noise_um,
            material: plant.material.to_string(),
            plan: plan.clone(),
            seed,
        }
    }

    /// The key's address: lower-case hex SHA-256 of its JSON.
    ///
    /// # Errors
    /// [`ClosedLoopError::Json`] if it cannot be serialised (a non-finite number).
    pub fn address(&self) -> Result<String, ClosedLoopError> {
        Ok(sha256_hex(serde_json::to_string(self)?.as_bytes()))
    }

    /// The bundle, commissioned now on the key's own truth (nothing the key leaves out reaches it).
    ///
    /// # Errors
    /// Those of [`commission_bundle`].
    pub fn commission(&self) -> Result<ModelBundle, ClosedLoopError> {
        let plant = CommissioningPlant {
            truth: &self.truth,
            instruments: self.instruments,
            force_noise_n: self.force_noise_n,
            gauge_noise_um: self.gauge_noise_um,
            material: &self.material,
        };
        commission_bundle(&plant, &self.plan, self.seed)
    }
}

/// How a [`CommissioningCache`] found its bundles.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct CacheCounts {
    /// Bundles commissioned by this process.
    pub computed: usize,
    /// Bundles read from the directory.
    pub from_disk: usize,
    /// Bundles already in memory (another run of this process asked first).
    pub from_memory: usize,
    /// Bundles that could not be written to the directory (the run went on with the bundle in
    /// memory).
    pub write_failures: usize,
}

type Slot = OnceLock<Result<Arc<ModelBundle>, Arc<ClosedLoopError>>>;

/// The slots of the keys asked for last, oldest first.
#[derive(Debug, Default)]
struct Recent {
    slots: HashMap<String, Arc<Slot>>,
    order: VecDeque<String>,
}

/// Bundles kept in memory (the most recently asked for; about 10 kB each): a batch's scenarios that
/// share a commissioning are usually near each other in the plan, the rest come from the disk.
pub const IN_MEMORY: usize = 64;

/// The commissioning cache: bundles by key, on disk under `dir` (none: in memory only) and the last
/// [`IN_MEMORY`] in memory.
#[derive(Debug, Default)]
pub struct CommissioningCache {
    dir: Option<PathBuf>,
    slots: Mutex<Recent>,
    computed: AtomicUsize,
    from_disk: AtomicUsize,
    from_memory: AtomicUsize,
    write_failures: AtomicUsize,
}

impl CommissioningCache {
    /// A cache keeping its bundles in `dir/commissioning/` (created when the first bundle is written).
    pub fn on_disk(dir: &Path) -> Self {
        Self {
            dir: Some(dir.to_path_buf()),
            ..Self::default()
        }
    }

    /// A cache in memory only.
    pub fn in_memory() -> Self {
        Self::default()
    }

    /// The directory of the bundles, if on disk.
    pub fn bundle_dir(&self) -> Option<PathBuf> {
        self.dir.as_ref().map(|d| d.join("commissioning"))
    }

    /// How the bundles were found so far.
    pub fn counts(&self) -> CacheCounts {
        CacheCounts {
            computed: self.computed.load(Ordering::Relaxed),
            from_disk: self.from_disk.load(Ordering::Relaxed),
            from_memory: self.from_memory.load(Ordering::Relaxed),
            write_failures: self.write_failures.load(Ordering::Relaxed),
        }
    }

    /// The bundle of `key`: from memory, from the directory, or commissioned now (and stored). A
    /// bundle file that cannot be read is commissioned again and rewritten.
    ///
    /// # Errors
    /// Those of the commissioning ([`CommissioningKey::commission`]), the same for every caller
    /// asking for the key.
    pub fn bundle(&self, key: &CommissioningKey) -> Result<Arc<ModelBundle>, ClosedLoopError> {
        let address = key.address()?;
        let slot = {
            let mut recent = self.slots.lock().unwrap_or_else(|e| e.into_inner());
            match recent.slots.get(&address) {
                Some(s) => s.clone(),
                None => {
                    if recent.order.len() >= IN_MEMORY
                        && let Some(oldest) = recent.order.pop_front()
                    {
                        recent.slots.remove(&oldest);
                    }
                    let s = Arc::new(Slot::new());
                    recent.slots.insert(address.clone(), s.clone());
                    recent.order.push_back(address.clone());
                    s
                }
            }
        };
        let mut fresh = false;
        let got = slot.get_or_init(|| {
            fresh = true;
            self.load_or_commission(key, &address)
        });
        if !fresh {
            self.from_memory.fetch_add(1, Ordering::Relaxed);
        }
        got.clone().map_err(ClosedLoopError::Shared)
    }

    fn path(&self, address: &str) -> Option<PathBuf> {
        self.bundle_dir().map(|d| d.join(format!("{address}.toml")))
    }

    fn load_or_commission(
        &self,
        key: &CommissioningKey,
        address: &str,
    ) -> Result<Arc<ModelBundle>, Arc<ClosedLoopError>> {
        if let Some(path) = self.path(address)
            && path.exists()
            && let Ok(file) = timed(Stage::CacheRead, || {
                ModelFile::<ModelBundle>::load(&path, &ModelBundle::KINDS)
            })
        {
            self.from_disk.fetch_add(1, Ordering::Relaxed);
            return Ok(Arc::new(file.model));
        }
        let bundle = timed(Stage::Commission, || key.commission()).map_err(Arc::new)?;
        self.computed.fetch_add(1, Ordering::Relaxed);
        if let Some(path) = self.path(address) {
            let saved = timed(Stage::Writing, || save(&path, address, &bundle));
            if saved.is_err() {
                self.write_failures.fetch_add(1, Ordering::Relaxed);
            }
        }
        Ok(Arc::new(bundle))
    }
}

/// Writes `bundle` to `path` (its directory created) as a model file of kind `bundle`.
fn save(path: &Path, address: &str, bundle: &ModelBundle) -> Result<(), ClosedLoopError> {
    if let Some(dir) = path.parent() {
        std::fs::create_dir_all(dir).map_err(|source| ClosedLoopError::CreateDir {
            path: dir.to_path_buf(),
            source,
        })?;
    }
    let provenance = Provenance::now(
        &format!("millcomp {}", env!("CARGO_PKG_VERSION")),
        &format!("commissioning cache entry, key SHA-256 {address}"),
    );
    ModelFile::new("bundle", bundle.clone(), provenance).save(path)?;
    Ok(())
}

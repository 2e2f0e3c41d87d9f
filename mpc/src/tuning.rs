//! A tuning rule for the `pid-tuned` baseline, fixed here so later work does not retune it: PI gains that
//! maximise the integral gain subject to a maximum-sensitivity bound `Ms ≤ 1.6` on the commissioned
//! spindle model (the MIGO design of Åström & Hägglund, *Advanced PID Control*, 2006, ch. 7: among all PI
//! controllers with robustness `Ms` the one with the largest `ki` minimises the integrated error after a
//! load disturbance). `Ms = max_ω |1/(1 + C(jω) G(jω))|`; `Ms ≤ 1.6` guarantees a gain margin ≥ 2.67 and a
//! phase margin ≥ 36°.
//!
//! The loop is evaluated exactly in frequency: `G(jω)` is the identified transfer function
//! `K ωn² [p/(s+p)] e^{−sTd} / (s² + 2ζωn s + ωn²)` with the dead time as a true delay, plus the extra delay
//! of the digital loop (half a sample of zero-order hold and one sample of computation). `C = kp + ki/s`.
//! No derivative: the gauge noise and the 0.04 N force quantisation would go straight to the amplifier, as
//! the thesis found ("the harshness of the output signal", `000_…txt` §5.2.5).

use millcomp_sim::spindle::PztSpindle;
use serde::Serialize;

use crate::identified::IdentifiedSpindle;

use crate::error::{MpcError, invalid};

/// The robustness bound of the rule.
pub const MS_MAX: f64 = 1.6;

/// A PI design and what it achieves.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct PiDesign {
    /// Proportional gain (V per µm of tip error).
    pub kp_v_per_um: f64,
    /// Integral gain (V per µm·s).
    pub ki_v_per_um_s: f64,
    /// Maximum sensitivity achieved.
    pub ms: f64,
    /// Gain crossover frequency of the loop (rad/s): where `|C G| = 1`.
    pub crossover_rad_s: f64,
}

/// Frequency response of the spindle model at `w` (rad/s), µm/V, with `delay_s` extra delay.
fn plant(s: &PztSpindle, w: f64, delay_s: f64) -> (f64, f64) {
    // K ωn² / (ωn² − w² + j 2ζωn w)
    let (re_d, im_d) = (
        s.wn_rad_s * s.wn_rad_s - w * w,
        2.0 * s.zeta * s.wn_rad_s * w,
    );
    let k = s.gain_um_per_v * s.wn_rad_s * s.wn_rad_s;
    let den = re_d * re_d + im_d * im_d;
    let (mut re, mut im) = (k * re_d / den, -k * im_d / den);
    if let Some(p) = s.pole_rad_s {
        // p / (p + j w)
        let d = p * p + w * w;
        let (a, b) = (p * p / d, -p * w / d);
        (re, im) = (re * a - im * b, re * b + im * a);
    }
    let td = s.dead_time_s.unwrap_or(0.0) + delay_s;
    let (c, sn) = ((w * td).cos(), -(w * td).sin());
    (re * c - im * sn, re * sn + im * c)
}

fn frequencies() -> Vec<f64> {
    // 10 rad/s … 1e6 rad/s, 1500 log-spaced points (resolves the resonance peak of ζ ≥ 0.05 to < 0.5 %)
    (0..1500)
        .map(|i| 10f64 * 10f64.powf(5.0 * i as f64 / 1499.0))
        .collect()
}

#[cfg(test)]
fn max_sensitivity(s: &PztSpindle, kp: f64, ki: f64, delay_s: f64, ws: &[f64]) -> f64 {
    max_sensitivity_on(&Response::of(s, delay_s, ws), kp, ki)
}

/// The plant's frequency response at each frequency of a grid: computed once per design, so the gain
/// search evaluates only the controller and the loop (the trigonometry of the delay is the cost).
struct Response {
    /// (ω, Re G(jω), Im G(jω)).
    points: Vec<(f64, f64, f64)>,
}

impl Response {
    fn of(s: &PztSpindle, delay_s: f64, ws: &[f64]) -> Self {
        Self {
            points: ws
                .iter()
                .map(|&w| {
                    let (gr, gi) = plant(s, w, delay_s);
                    (w, gr, gi)
                })
                .collect(),
        }
    }
}

/// `max_ω |1/(1 + C(jω) G(jω))|` over the grid of `g`, for `C = kp + ki/s`: the same arithmetic, value
/// for value, as evaluating the plant at each frequency anew.
fn max_sensitivity_on(g: &Response, kp: f64, ki: f64) -> f64 {
    g.points
        .iter()
        .map(|&(w, gr, gi)| {
            // C = kp − j ki/w
            let (cr, ci) = (kp, -ki / w);
            let (lr, li) = (cr * gr - ci * gi, cr * gi + ci * gr);
            1.0 / ((1.0 + lr).powi(2) + li * li).sqrt()
        })
        .fold(0.0, f64::max)
}

/// The MIGO PI of the module docs for the spindle model `s` in a digital loop sampled every `dt_s`.
///
/// # Errors
/// [`MpcError::InvalidConfig`] for a non-positive `dt_s` or `ms_max ≤ 1`, or when no PI meets the bound.
///
/// # Examples
/// ```
/// use millcomp_models::SpindleModel;
/// use millcomp_mpc::identified::IdentifiedSpindle;
/// // an identified spindle: 0.05 µm/V, ζ 0.31, ωn 2811 rad/s, a pole at 37 000 rad/s, 0.1 ms dead time
/// let s = IdentifiedSpindle::new(&SpindleModel {
///     gain_um_per_v: 0.05, zeta: 0.31, wn_rad_s: 2811.0, pole_rad_s: Some(37_000.0),
///     dead_time_s: Some(1e-4), dead_time_pade_order: Some(2), covariance: Default::default(),
/// }).unwrap();
/// let d = millcomp_mpc::tuning::pi_max_sensitivity(&s, 1.6, 5e-5).unwrap();
/// assert!(d.ms <= 1.6 + 1e-9);
/// assert!(d.ki_v_per_um_s > 0.0 && d.kp_v_per_um >= 0.0);
/// ```
pub fn pi_max_sensitivity(
    s: &IdentifiedSpindle,
    ms_max: f64,
    dt_s: f64,
) -> Result<PiDesign, MpcError> {
    let p = s.plant();
    // The design is a pure function of the five numbers of the transfer function, the bound and the
    // period, and costs ~0.1 s (some 10⁵ sensitivity sweeps of 1 500 frequencies); a batch builds a
    // `pid-tuned` for every condition, most of them on a spindle model it has already designed for
    // (one per commissioning), so designs are remembered per key — the same bits in, the same design
    // out. Bounded: the memory is emptied when it holds `DESIGN_MEMORY` designs.
    let key = [
        p.gain_um_per_v,
        p.zeta,
        p.wn_rad_s,
        p.pole_rad_s.unwrap_or(f64::NAN),
        p.dead_time_s.unwrap_or(f64::NAN),
        ms_max,
        dt_s,
    ]
    .map(f64::to_bits);
    let memory = DESIGNS.get_or_init(Default::default);
    if let Some(d) = memory.lock().ok().and_then(|m| m.get(&key).copied()) {
        return Ok(d);
    }
    let d = pi_max_sensitivity_of(p, ms_max, dt_s)?;
    if let Ok(mut m) = memory.lock() {
        if m.len() >= DESIGN_MEMORY {
            m.clear();
        }
        m.insert(key, d);
    }
    Ok(d)
}

/// How many designs [`pi_max_sensitivity`] remembers (a few hundred bytes each).
const DESIGN_MEMORY: usize = 1024;

/// The designs made in this process, by the bits of their inputs.
type DesignMemory = std::sync::Mutex<std::collections::HashMap<[u64; 7], PiDesign>>;
static DESIGNS: std::sync::OnceLock<DesignMemory> = std::sync::OnceLock::new();

fn pi_max_sensitivity_of(s: &PztSpindle, ms_max: f64, dt_s: f64) -> Result<PiDesign, MpcError> {
    if !(dt_s.is_finite() && dt_s > 0.0) {
        return Err(invalid("dt_s", dt_s, "finite and > 0"));
    }
    if !(ms_max.is_finite() && ms_max > 1.0) {
        return Err(invalid("ms_max", ms_max, "finite and > 1"));
    }
    let delay = 1.5 * dt_s;
    let ws = frequencies();
    let response = Response::of(s, delay, &ws);
    // scale of the gains: the P-only gain that puts |G| kp = 1 at the plant's natural frequency
    let g_wn = {
        let (a, b) = plant(s, s.wn_rad_s, delay);
        (a * a + b * b).sqrt()
    };
    let kp_scale = 1.0 / g_wn;
    // Ms is continuous in the gains and crosses the bound before any closed-loop pole can cross into the
    // right half plane, so the admissible region is scanned *from zero gain outwards* (never jumping over
    // an unstable region in which the Nyquist curve passes −1 on the far side with a small |1 + L|)
    let mut best: Option<PiDesign> = None;
    for i in 0..=200 {
        let kp = kp_scale * 2.0 * i as f64 / 200.0;
        if max_sensitivity_on(&response, kp, 0.0) > ms_max {
            break;
        }
        // ki from tiny upwards in 2 % steps to the first violation, then bisect
        let mut lo = 0.0;
        let mut hi = kp_scale * 1.0;
        let mut violated = false;
        for _ in 0..2000 {
            if max_sensitivity_on(&response, kp, hi) > ms_max {
                violated = true;
                break;
            }
            lo = hi;
            hi *= 1.02;
        }
        if !violated {
            continue;
        }
        for _ in 0..40 {
            let mid = 0.5 * (lo + hi);
            if max_sensitivity_on(&response, kp, mid) <= ms_max {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        if lo > 0.0 && best.is_none_or(|b| lo > b.ki_v_per_um_s) {
            best = Some(PiDesign {
                kp_v_per_um: kp,
                ki_v_per_um_s: lo,
                ms: max_sensitivity_on(&response, kp, lo),
                crossover_rad_s: 0.0,
            });
        }
    }
    let mut d = best.ok_or_else(|| {
        invalid(
            "ms_max",
            ms_max,
            "a bound some PI controller meets on this spindle model",
        )
    })?;
    d.crossover_rad_s = ws
        .iter()
        .copied()
        .find(|&w| {
            let (gr, gi) = plant(s, w, delay);
            let c = (d.kp_v_per_um.powi(2) + (d.ki_v_per_um_s / w).powi(2)).sqrt();
            c * (gr * gr + gi * gi).sqrt() < 1.0
        })
        .unwrap_or(f64::NAN);
    Ok(d)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_remembered_design_is_the_design() {
        use millcomp_models::SpindleModel;
        let model = SpindleModel {
            gain_um_per_v: 0.047,
            zeta: 0.29,
            wn_rad_s: 2903.0,
            pole_rad_s: Some(35_000.0),
            dead_time_s: Some(1e-4),
            dead_time_pade_order: Some(2),
            covariance: Default::default(),
        };
        let s = IdentifiedSpindle::new(&model).unwrap();
        let first = pi_max_sensitivity(&s, MS_MAX, 5e-5).unwrap();
        let again = pi_max_sensitivity(&s, MS_MAX, 5e-5).unwrap();
        let fresh = pi_max_sensitivity_of(s.plant(), MS_MAX, 5e-5).unwrap();
        assert_eq!(first, fresh);
        assert_eq!(again, fresh);
        // another period is another design
        let other = pi_max_sensitivity(&s, MS_MAX, 1e-4).unwrap();
        assert_ne!(other.ki_v_per_um_s, fresh.ki_v_per_um_s);
    }

    #[test]
    fn the_design_meets_its_bound_and_a_larger_ki_would_not() {
        let s = PztSpindle::default();
        let d = pi_max_sensitivity_of(&s, MS_MAX, 5e-5).unwrap();
        let ws = frequencies();
        assert!(d.ms <= MS_MAX + 1e-9);
        let worse = max_sensitivity(&s, d.kp_v_per_um, d.ki_v_per_um_s * 1.01, 1.5 * 5e-5, &ws);
        assert!(worse > MS_MAX, "ki is not the largest: {worse}");
    }

    #[test]
    fn a_first_order_lag_check_of_the_frequency_response() {
        // without resonance, pole and delay the response at ωn is K/(j 2ζ) for ζ = 0.5: magnitude K
        let s = PztSpindle::new(0.05, 0.5, 1000.0, None, None).unwrap();
        let (re, im) = plant(&s, 1000.0, 0.0);
        assert!(re.abs() < 1e-12 && (im + 0.05).abs() < 1e-12, "{re} {im}");
    }
}

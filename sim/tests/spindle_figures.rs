//! The PZT spindle plant fitted to all published figures at once (`000_…txt` §5.2.4–5.2.5).
use crate::common;

use approx::assert_relative_eq;
use argmin::core::{CostFunction, Error, Executor};
use argmin::solver::neldermead::NelderMead;
use millcomp_sim::spindle::PztSpindle;
use millcomp_sim::spindle_figures::{
    FITTED, PUBLISHED, PlantStructure, STRUCTURE_FITS, SpindleFigures, evaluate, fit_cost,
    p_critical_gain,
};
use nalgebra::DVector;

#[test]
fn fitted_plant_meets_open_loop_figures_and_reports_residuals() {
    let f = evaluate(&FITTED.spindle()).unwrap();
    let r = f.relative_residuals(&PUBLISHED);
    for (k, n) in SpindleFigures::NAMES.iter().enumerate() {
        eprintln!(
            "{n:26} model {:>10.4} published {:>10.4} residual {:+.3}",
            f.as_array()[k],
            PUBLISHED.as_array()[k],
            r[k]
        );
    }
    // 000 §5.2.4: 20 % overshoot, 1.38 ms rise (0–90 %), issue tolerance 5 %
    assert_relative_eq!(
        f.open_loop_overshoot_pct,
        20.0,
        max_relative = common::SPINDLE_OL_REL
    );
    assert_relative_eq!(
        f.open_loop_rise_ms,
        1.38,
        max_relative = common::SPINDLE_OL_REL
    );
    // the PID design overshoot (9 %, §5.2.4) and tuned overshoot (6 %, §5.2.5) are also met within 5 %;
    // the rise times and kc are not (documented in spindle_figures::FITTED)
    assert_relative_eq!(f.pid_design_overshoot_pct, 9.0, max_relative = 0.05);
    assert_relative_eq!(f.pid_tuned_overshoot_pct, 6.0, max_relative = 0.05);
    assert!(f.p_critical_gain.is_finite() && f.p_critical_gain > 500.0);
}

#[test]
fn recorded_structure_fits_reproduce_and_pole_plus_delay_is_best() {
    let mut costs = Vec::new();
    for (st, x, cost) in STRUCTURE_FITS {
        let c = fit_cost(st, x);
        // the recorded cost is printed with 4–5 significant digits
        assert_relative_eq!(c, cost, max_relative = 1e-3);
        costs.push((st, c));
    }
    let best = costs.iter().min_by(|a, b| a.1.total_cmp(&b.1)).unwrap();
    assert_eq!(best.0, PlantStructure::SecondOrderPoleDelay);
    // FITTED is that structure's optimum
    let s = PlantStructure::SecondOrderPoleDelay
        .spindle(STRUCTURE_FITS[3].1)
        .unwrap();
    assert_relative_eq!(s.wn_rad_s, FITTED.wn_rad_s, max_relative = 1e-6);
    assert_relative_eq!(
        s.loop_v_per_unit,
        FITTED.loop_v_per_unit,
        max_relative = 1e-6
    );
}

struct Cost;
impl CostFunction for Cost {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, x: &Self::Param) -> Result<f64, Error> {
        Ok(fit_cost(PlantStructure::SecondOrderPoleDelay, x.as_slice()))
    }
}

#[test]
fn fitted_constants_are_a_local_least_squares_optimum() {
    // A short Nelder–Mead (argmin 0.11) from the stored point must not find a materially better fit.
    let x0 = STRUCTURE_FITS[3].1.to_vec();
    let c0 = fit_cost(PlantStructure::SecondOrderPoleDelay, &x0);
    let mut simplex = vec![DVector::from_vec(x0.clone())];
    for i in 0..x0.len() {
        let mut v = x0.clone();
        v[i] += if i == 0 { 0.01 } else { 0.05 };
        simplex.push(DVector::from_vec(v));
    }
    let res = Executor::new(Cost, NelderMead::new(simplex))
        .configure(|s| s.max_iters(40))
        .run()
        .unwrap();
    let c1 = res.state().get_best_cost();
    // 2 %: the step-figure cost is piecewise smooth (interpolated crossings), small gains are noise
    assert!(c1 > 0.98 * c0, "{c1} vs {c0}");
}

#[test]
fn critical_gain_bisection_matches_routh_for_three_poles() {
    // Routh: s³ + (a+p)s² + (ωn²+ap)s + ωn²p(1+K) with a = 2ζωn → K_crit = (a+p)(ωn²+ap)/(ωn²p) − 1
    let s = PztSpindle::new(0.05, 0.46, 1479.0, Some(20_000.0), None).unwrap();
    let (z, wn, p) = (0.46f64, 1479.0f64, 20_000.0f64);
    let a = 2.0 * z * wn;
    let k_loop = (a + p) * (wn * wn + a * p) / (wn * wn * p) - 1.0;
    let kc = k_loop / (s.gain_um_per_v * s.loop_v_per_unit);
    assert_relative_eq!(p_critical_gain(&s).unwrap(), kc, max_relative = 1e-6);
    // pure 2nd order: never unstable under P
    let s2 = PztSpindle::new(0.05, 0.46, 1479.0, None, None).unwrap();
    assert!(p_critical_gain(&s2).unwrap().is_infinite());
}

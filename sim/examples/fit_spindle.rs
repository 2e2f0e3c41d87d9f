//! Least-squares fit of the PZT spindle plant to all published figures at once (`000_…txt` §5.2.4–5.2.5),
//! for each candidate structure, with argmin's Nelder–Mead (physics stays solver-free; the solver lives
//! here). Prints the best coordinates, the fitted constants and every figure's residual.
//!
//! Run: `cargo run --release -p millcomp-sim --example fit_spindle`
use argmin::core::{CostFunction, Error, Executor, State};
use argmin::solver::neldermead::NelderMead;
use millcomp_sim::spindle_figures::{
    PUBLISHED, PlantStructure, SpindleFigures, evaluate, fit_cost,
};
use nalgebra::DVector;

struct Cost(PlantStructure);

impl CostFunction for Cost {
    type Param = DVector<f64>;
    type Output = f64;
    fn cost(&self, x: &Self::Param) -> Result<f64, Error> {
        Ok(fit_cost(self.0, x.as_slice()))
    }
}

fn simplex(x0: &[f64]) -> Vec<DVector<f64>> {
    let mut s = vec![DVector::from_column_slice(x0)];
    for i in 0..x0.len() {
        let mut v = x0.to_vec();
        v[i] += if i == 0 { 0.05 } else { 0.3 };
        s.push(DVector::from_vec(v));
    }
    s
}

fn main() -> Result<(), Error> {
    for st in PlantStructure::ALL {
        let mut best: Option<(f64, Vec<f64>)> = None;
        // multi-start over the loop gain, the extra pole and the dead time (the landscape has basins)
        let names = st.coordinate_names();
        let mut starts = Vec::new();
        for lk in [1e-4f64, 1e-3, 1e-2] {
            for p in [2e3f64, 1e4, 5e4] {
                for td in [1e-4f64, 4e-4] {
                    let mut x0 = st.initial();
                    x0[1] = 1479f64.ln();
                    let n = x0.len();
                    x0[n - 1] = lk.ln();
                    if let Some(i) = names.iter().position(|n| *n == "ln_pole_rad_s") {
                        x0[i] = p.ln();
                    }
                    if let Some(i) = names.iter().position(|n| *n == "ln_dead_time_s") {
                        x0[i] = td.ln();
                    }
                    if !starts.contains(&x0) {
                        starts.push(x0);
                    }
                }
            }
        }
        for x0 in starts {
            let mut x = x0;
            for _restart in 0..3 {
                let solver = NelderMead::new(simplex(&x)).with_sd_tolerance(1e-10)?;
                let res = Executor::new(Cost(st), solver)
                    .configure(|s| s.max_iters(500))
                    .run()?;
                x = res
                    .state()
                    .get_best_param()
                    .map(|p| p.as_slice().to_vec())
                    .unwrap_or(x);
            }
            let c = fit_cost(st, &x);
            if best.as_ref().is_none_or(|b| c < b.0) {
                best = Some((c, x));
            }
        }
        let (c, x) = best.expect("at least one start");
        let s = st.spindle(&x).expect("valid");
        println!("structure {st:?}: weighted cost {c:.5}");
        println!("  coords {:?} = {:?}", st.coordinate_names(), x);
        println!(
            "  zeta {:.5} wn {:.3} rad/s pole {:?} dead {:?} loop_v_per_unit {:.6e} (loop gain {:.6e} um/um)",
            s.zeta,
            s.wn_rad_s,
            s.pole_rad_s,
            s.dead_time_s,
            s.loop_v_per_unit,
            s.loop_v_per_unit * s.gain_um_per_v
        );
        match evaluate(&s) {
            Ok(f) => print_figs(&f),
            Err(e) => println!("  evaluate failed: {e}"),
        }
    }
    Ok(())
}

fn print_figs(f: &SpindleFigures) {
    let r = f.relative_residuals(&PUBLISHED);
    for (k, name) in SpindleFigures::NAMES.iter().enumerate() {
        println!(
            "    {name:26} model {:>12.4}  published {:>10.4}  residual {:>+8.3}",
            f.as_array()[k],
            PUBLISHED.as_array()[k],
            r[k]
        );
    }
}

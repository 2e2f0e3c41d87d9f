//! Beyond the candidate list (issue 50): an effect whose shape no family has is reported as an
//! `unlisted` term following the right variable; nothing hidden, nothing unlisted.

use millcomp_diagnose::{DiagnoseOptions, Diagnoser, Measured};
use millcomp_synthetic::variants::{Row, VariantSpec, draw, study_session};

/// A periodic error in the position along the groove (a leadscrew's pitch error on the axis that
/// feeds along the groove): `a·sin(2π·x/period)`. Test-only: no family has a periodic shape, and
/// nothing in `diagnose` is built from it.
pub fn periodic_um(x_mm: f64, amplitude_um: f64, period_mm: f64) -> f64 {
    amplitude_um * (std::f64::consts::TAU * x_mm / period_mm).sin()
}

#[test]
fn explore() {
    let session = study_session();
    let d = Diagnoser::new(&session, &DiagnoseOptions::default()).unwrap();
    let pts = d.session_model().points();
    let xmin = pts.iter().map(|p| p.x_mm).fold(f64::INFINITY, f64::min);
    let xmax = pts.iter().map(|p| p.x_mm).fold(f64::NEG_INFINITY, f64::max);
    eprintln!("x_mm {xmin}..{xmax}");
    for seed in [9_200_001u64, 9_200_002] {
        let v = draw(&session, &VariantSpec { row: Row::None, effects: vec![], seed }).unwrap();
        let mut points = v.points.clone();
        for (p, c) in points.iter_mut().zip(pts) {
            p.depth_meas_um += periodic_um(c.x_mm, 1.0, (xmax - xmin) / 3.0);
        }
        let t = std::time::Instant::now();
        let rep = d.run(&Measured::new("p.csv", points)).unwrap();
        eprintln!("{:?} named {:?} verdict {} rms {} -> {} ; {:?}", t.elapsed(), rep.named, rep.verdict, rep.nuisance_rms_um, rep.final_rms_um, rep.notes);
        eprintln!("{}", serde_json::to_string_pretty(&rep.unlisted).unwrap());
        let rep0 = d.run(&Measured::new("n.csv", v.points.clone())).unwrap();
        eprintln!("null: named {:?} unlisted {} notes {:?}", rep0.named, rep0.unlisted.len(), rep0.notes);
    }
}

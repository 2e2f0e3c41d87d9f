//! The thesis groove (`000_…txt` ch. 6–7) on the simulated PZT spindle: uncompensated, open-loop
//! (force-model tool-path pre-shift, ch. 6) and closed-loop PI with the thesis signal chain (ch. 7).
//!
//! Run: `cargo run --release -p millcomp-sim --example groove_demo [tilt_deg]`
use millcomp_sim::filters::{FirstOrderFilter, PeakHold};
use millcomp_sim::groove::{GrooveConfig, GrooveStage, GrooveStepOutput, profile};
use millcomp_sim::spindle_figures::PID_TUNED;

fn pp(run: &[GrooveStepOutput]) -> (f64, f64) {
    let p = profile(run, 0.1).expect("spacing");
    // skip the first 1 mm (entry transient) as the thesis' error plots do not start at zero depth either
    let errs: Vec<f64> = p.iter().filter(|r| r.0 >= 1.0).map(|r| r.1 - r.2).collect();
    let max = errs.iter().cloned().fold(f64::NEG_INFINITY, f64::max);
    let min = errs.iter().cloned().fold(f64::INFINITY, f64::min);
    (max - min, *errs.last().unwrap_or(&0.0))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let tilt: f64 = std::env::args()
        .nth(1)
        .map(|s| s.parse())
        .transpose()?
        .unwrap_or(20.0);
    let dt = 1.0 / 20_000.0;
    let cfg = GrooveConfig::thesis(tilt, 8.0)?;

    // 1. uncompensated
    let mut st = GrooveStage::new(cfg.clone(), dt)?;
    let run = st.run(|_| 0.0);
    let (pp0, end0) = pp(&run);
    println!("tilt {tilt}°: uncompensated  p-p error {pp0:6.2} µm, deep-end error {end0:6.2} µm");

    // 2. closed loop (§7.2): peak-hold → first-order filter → wanted tip = F·C/sin α; PI on the gauge
    let mut st = GrooveStage::new(cfg.clone(), dt)?;
    let mut ph = PeakHold::thesis(cfg.program.speed_rpm)?;
    let mut lp = FirstOrderFilter::thesis(dt)?;
    let c = st.z_compliance_um_per_n();
    let k = st.tip_per_z();
    let v_per_unit = cfg.spindle.loop_v_per_unit;
    let (kp, ki, _) = PID_TUNED;
    let mut integ = 0.0;
    let run = st.run(|last| {
        let Some(o) = last else { return 0.0 };
        let f = lp.step(ph.step(o.force_meas_n, dt).max(0.0));
        let wanted_tip = (f * c * k).clamp(0.0, 50.0);
        let e = wanted_tip - o.gauge_um;
        let u = kp * e + ki * integ;
        let v = v_per_unit * u;
        // anti-windup: integrate only while the actuator is not saturated
        if (0.0..=1000.0).contains(&v) {
            integ += e * dt;
        }
        v
    });
    let (pp1, end1) = pp(&run);
    println!("tilt {tilt}°: closed-loop PI p-p error {pp1:6.2} µm, deep-end error {end1:6.2} µm");
    Ok(())
}

//! The NC feed-axis stage's run (003): the measured wall's metrics and the commissioned models.

use millcomp_closedloop::nc_axis::NcAxisReport;

/// Print the wall's metrics and the commissioned models of one `nc_axis` run.
pub fn print_wall(nc: &NcAxisReport) {
    let w = &nc.wall;
    let windows: Vec<String> = w
        .windows_mm
        .iter()
        .map(|[a, b]| format!("{a:.1}-{b:.1}"))
        .collect();
    println!("wall (lower wall, + = material left, - = undersize):");
    println!(
        "  static error {:.2} um over {} mm (uncompensated {:.2} um: {:.2} % removed)",
        w.static_error_um,
        windows.join(", "),
        w.static_uncompensated_um,
        w.static_removed_pct
    );
    if let (Some(step), Some(peak), Some(signed), Some(excess)) = (
        w.deflection_step_um,
        w.feed_step_peak_um,
        w.feed_step_peak_signed_um,
        w.feed_step_excess_um,
    ) {
        println!(
            "  feed step: deflection step {step:.2} um (model output); peak |error| {peak:.2} um ({signed:+.2}), excess over the settled wall {excess:.2} um, ringing of the correction {:.2} um rms",
            w.feed_step_oscillation_um.unwrap_or(f64::NAN)
        );
    }
    println!(
        "  exit: undersize {:.2} um (wall from {:.2} to {:.2} um over the last 9 mm)",
        w.exit_undersize_um, w.exit_min_um, w.exit_max_um
    );
    let um = |v: Option<f64>| v.map_or("-".to_string(), |v| format!("{v:.2}"));
    println!(
        "  physical limit (any controller, one correction per NC cycle through the true axis, the deflection known in advance):"
    );
    if w.feed_step_peak_um.is_some() {
        println!(
            "    feed step: peak >= {} um, excess >= {} um",
            um(w.feed_step_peak_bound_um),
            um(w.feed_step_excess_bound_um)
        );
    }
    println!(
        "    exit: wall within +/- {} um at best",
        um(w.exit_bound_um)
    );
    if let Some(c) = &w.certainty_equivalent {
        println!(
            "  certainty-equivalent wall (the measured force known in advance, over the commissioned stiffness):"
        );
        println!(
            "    static error {:.2} um; feed step peak {} um, excess {} um; exit undersize {:.2} um; peak-to-peak {:.2} um",
            c.static_error_um,
            um(c.feed_step_peak_um),
            um(c.feed_step_excess_um),
            c.exit_undersize_um,
            c.pp_um
        );
    }
    println!(
        "commissioned models (estimate, SE; the truth's value where its structure is the same):"
    );
    for l in &nc.models {
        let truth = if l.truth.is_finite() {
            format!("{:.4}", l.truth)
        } else {
            "-".into()
        };
        println!(
            "  {:<30} {:>12.4} {:>10.4}   truth {truth}",
            l.name, l.estimate, l.std_err
        );
    }
}

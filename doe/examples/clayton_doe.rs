//! The DOE of the Clayton thesis (seed 000, §3.5): generate the 2³ treatment matrix of Table 3-2, analyse the
//! measured maximum forces of Table 3-3, and evaluate the fitted response surface. The library returns data;
//! `millcomp doe analyze` prints it as tables, `--plots DIR` draws the plots and `--save model.toml` saves
//! the model.
//!
//! Run: `cargo run -p millcomp-doe --example clayton_doe`.

use millcomp_doe::{
    AnalysisInput, DesignKind, DesignRequest, FactorSpec, ModelSpec, Values, analyze, generate,
    power, response_surface,
};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    // Table 3-2 factors → randomised 2³ (the thesis randomised with JMP; here ChaCha8 with a fixed seed).
    let factors = FactorSpec::parse_list("depth_um=100:200,speed_rpm=10000:20000,upfeed_um=10:20")?;
    let mut req = DesignRequest::new(DesignKind::Full, factors);
    req.seed = Some(2008);
    let design = generate(&req)?;
    assert_eq!(design.n_runs(), 8);
    for run in &design.runs {
        let levels: Vec<String> = run.actual.iter().map(|l| l.to_string()).collect();
        println!(
            "run {} (standard order {}): {}",
            run.run_order,
            run.std_order,
            levels.join(", ")
        );
    }

    // Table 3-3: trials as published (depth µm, speed rpm, upfeed µm/rev; max X/Y/Z force in N).
    let depth = [200., 100., 100., 200., 200., 100., 200., 100.];
    let speed = [1e4, 1e4, 2e4, 2e4, 2e4, 2e4, 1e4, 1e4];
    let upfeed = [20., 20., 10., 10., 20., 20., 10., 10.];
    let forces = [
        ("fx_n", [3.34, 1.78, 0.94, 1.91, 3.60, 2.20, 2.20, 1.00]),
        ("fy_n", [1.75, 1.33, 0.93, 1.64, 2.30, 1.75, 2.10, 1.10]),
        ("fz_n", [2.17, 1.24, 0.59, 0.83, 2.00, 1.50, 1.40, 0.82]),
    ];
    let fcols = vec![
        ("depth_um".to_string(), Values::F64(depth.to_vec())),
        ("speed_rpm".to_string(), Values::F64(speed.to_vec())),
        ("upfeed_um".to_string(), Values::F64(upfeed.to_vec())),
    ];
    for (name, y) in forces {
        let input = AnalysisInput {
            factors: fcols.clone(),
            response_name: name.into(),
            response: Values::F64(y.to_vec()),
            model: ModelSpec::Main,
        };
        let a = analyze(&input)?;
        println!("\n{name}: R² = {:.4}", a.r_squared);
        for t in &a.terms {
            println!(
                "  {:<10} effect {:>8.4} N   p = {:.4}",
                t.term,
                t.effect.unwrap_or(f64::NAN),
                t.p_value.unwrap_or(f64::NAN)
            );
        }
        if name == "fx_n" {
            // §3.5: depth and upfeed are significant for the X force at 5 %, speed is not (statsmodels 0.15.0
            // anova_lm(typ=2) gives p = 0.0016, 0.652, 0.0020; doe's golden ANOVA test).
            let p: Vec<f64> = a.terms.iter().map(|t| t.p_value.unwrap()).collect();
            assert!(p[0] < 0.05 && p[1] > 0.05 && p[2] < 0.05, "{p:?}");
        }
        let model = response_surface(&a)?;
        println!(
            "predicted {name} at 150 µm, 15 000 rpm, 15 µm/rev: {:.3} N",
            model.predict(&[
                ("depth_um", 150.0),
                ("speed_rpm", 15000.0),
                ("upfeed_um", 15.0)
            ])?
        );
    }

    // How large an effect does this 8-run design detect with 80 % power (σ from the X-force fit ≈ 0.24 N)?
    for effect in [0.4, 0.6, 0.8] {
        let p = power(&fcols, &ModelSpec::Main, effect, 0.24, 0.05)?;
        println!("effect {effect:.1} N: power {:.2}", p.terms[0].power);
    }
    Ok(())
}

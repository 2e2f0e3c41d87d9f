//! `millcomp batch`: every scenario × controller closed-loop run, in parallel, resumable and shardable;
//! `millcomp batch merge DIR...` joins the slices. The batch is one library call
//! (`millcomp_closedloop::batch::run_batch`); here the arguments are parsed (including `--doe "ARGS"`,
//! the `doe design` options given as one string) and the summary is printed (`present::batch`).

use anyhow::Context;
use clap::Parser;
use millcomp_closedloop::ClosedLoopError;
use millcomp_closedloop::batch::plan::Shard;
use millcomp_closedloop::batch::{
    BatchRequest, BatchSummary, ProgressMode, ScenarioSource, estimate_request, merge_batch,
    run_plan, signals,
};
use millcomp_datasets::Table;

use crate::cli::{BatchArgs, BatchCommand, DoeDesignArgs};
use crate::cmd::print_json;
use crate::present::batch::{print_estimate, print_summary};

/// `--doe "ARGS"` parsed with the same options as `millcomp doe design`.
#[derive(Debug, Parser)]
#[command(name = "--doe", no_binary_name = true)]
struct DoeWrap {
    #[command(flatten)]
    args: DoeDesignArgs,
}

/// Runs the verb.
pub fn run(args: BatchArgs, json: bool) -> anyhow::Result<()> {
    if let Some(BatchCommand::Merge(m)) = &args.command {
        // the merged results must not overwrite a slice's
        if let Some(d) = m
            .dirs
            .iter()
            .find(|d| crate::cmd::guard::same_file(d, &m.out))
        {
            anyhow::bail!(
                "--out {}: that is the slice {} — the merged results would overwrite it; merge into \
                 another directory",
                m.out.display(),
                d.display()
            );
        }
        let summary = merge_batch(&m.dirs, &m.out, true)?;
        return show(&summary, json, &format!("merged {} slices", m.dirs.len()));
    }
    let shard = match &args.shard {
        Some(s) => Shard::parse(s)?,
        None => Shard::from_env(|k| std::env::var(k).ok())?.unwrap_or(Shard::ALL),
    };
    // the output directory's files are not the scenario file
    crate::cmd::guard::Inputs::new()
        .add_opt("--scenarios", args.scenarios.as_deref())
        .check_dir("--out", &args.out, |rel| {
            [
                "results.csv",
                "results.parquet",
                "summary.json",
                "invocation.json",
            ]
            .iter()
            .any(|n| rel == std::path::Path::new(n))
                || rel.starts_with("plots")
                || rel.starts_with("runs")
        })?;
    let scenarios = match (&args.scenarios, &args.doe) {
        (Some(path), None) => ScenarioSource::File {
            path: path.clone(),
            columns: args.columns.clone(),
        },
        (None, Some(d)) => ScenarioSource::Table(design_table(d)?),
        _ => anyhow::bail!("give either --scenarios FILE or --doe \"DESIGN ARGS\" (one of them)"),
    };
    let mut req = BatchRequest::new(scenarios, &args.controllers, &args.out);
    req.shard = shard;
    req.threads = args.threads;
    req.cache = args.cache.clone();
    req.progress = if json || args.quiet {
        ProgressMode::Quiet
    } else {
        ProgressMode::Auto
    };
    req.stop_on_signals = true;
    let (plan, estimate) = estimate_request(&req).with_context(|| match &args.scenarios {
        Some(p) => format!("reading the scenarios {}", p.display()),
        None => "--doe: the scenarios of the design".to_string(),
    })?;
    if args.dry_run {
        if json {
            return print_json(&serde_json::json!({
                "fingerprint": plan.fingerprint,
                "estimate": estimate,
            }));
        }
        print_estimate(&plan, &estimate, shard);
        return Ok(());
    }
    match run_plan(&plan, &req) {
        Ok(summary) => {
            let what = if shard == Shard::ALL {
                "batch".to_string()
            } else {
                format!("shard {}/{}", shard.index, shard.count)
            };
            show(&summary, json, &what)
        }
        // stopped by SIGTERM or SIGINT: the runs are stored; end as the signal would have
        Err(e @ ClosedLoopError::Interrupted { .. }) => {
            eprintln!("batch: {e}");
            std::process::exit(signals::exit_status().map_or(1, i32::from));
        }
        Err(e) => Err(e.into()),
    }
}

/// Splits a command line into words: whitespace separates, single and double quotes group.
pub fn split_words(text: &str) -> anyhow::Result<Vec<String>> {
    let mut out = Vec::new();
    let mut cur = String::new();
    let mut quote: Option<char> = None;
    let mut in_word = false;
    for ch in text.chars() {
        match quote {
            Some(q) if ch == q => quote = None,
            Some(_) => cur.push(ch),
            None if ch == '"' || ch == '\'' => {
                quote = Some(ch);
                in_word = true;
            }
            None if ch.is_whitespace() => {
                if in_word {
                    out.push(std::mem::take(&mut cur));
                    in_word = false;
                }
            }
            None => {
                cur.push(ch);
                in_word = true;
            }
        }
    }
    if let Some(q) = quote {
        anyhow::bail!("unbalanced {q} quote in `{text}`");
    }
    if in_word {
        out.push(cur);
    }
    Ok(out)
}

/// The scenario table of a design generated from `doe design` arguments given as one string (its
/// `--out`, if given, written).
pub fn design_table(doe_args: &str) -> anyhow::Result<Table> {
    let words = split_words(doe_args).context("--doe")?;
    let args = DoeWrap::try_parse_from(&words)
        .map_err(|e| anyhow::anyhow!("--doe `{doe_args}`: {}", e.render().to_string().trim()))?
        .args;
    let req = crate::cmd::doe::design_request(&args).context("--doe")?;
    let table = ScenarioSource::Design(req)
        .table()
        .context("--doe: generating the design")?;
    if let Some(out) = &args.out {
        millcomp_datasets::write_table(&table, out)
            .with_context(|| format!("--doe --out {}", out.display()))?;
    }
    Ok(table)
}

/// Runs `f` on a rayon pool of `threads` workers (the global pool when `None`).
pub fn with_threads<T: Send>(
    threads: Option<usize>,
    f: impl FnOnce() -> anyhow::Result<T> + Send,
) -> anyhow::Result<T> {
    match threads {
        None => f(),
        Some(0) => anyhow::bail!("--threads must be at least 1"),
        Some(n) => rayon::ThreadPoolBuilder::new()
            .num_threads(n)
            .build()
            .context("building the worker pool")?
            .install(f),
    }
}

fn show(s: &BatchSummary, json: bool, what: &str) -> anyhow::Result<()> {
    if json {
        return print_json(s);
    }
    print_summary(s, what);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use millcomp_closedloop::batch::factors::scenarios_from_table;
    use millcomp_closedloop::error_chain;

    #[test]
    fn words_split_like_a_shell() {
        assert_eq!(
            split_words(r#"--design full --factors "a=1:2, b=3:4" --seed 1"#).unwrap(),
            vec![
                "--design",
                "full",
                "--factors",
                "a=1:2, b=3:4",
                "--seed",
                "1"
            ]
        );
        assert!(split_words("--factors \"a").is_err());
    }

    #[test]
    fn doe_args_make_a_scenario_table() {
        let t = design_table(
            "--design fractional --factors tilt_deg=20:40,depth_um=60:100,upfeed_um=8:12,wearland_um=4:12 --resolution 4 --seed 1",
        )
        .unwrap();
        // A 2^(4-1) resolution IV design has 8 runs.
        assert_eq!(t.n_rows(), 8);
        let (names, specs) = scenarios_from_table(&t).unwrap();
        assert_eq!(
            names,
            vec!["tilt_deg", "depth_um", "upfeed_um", "wearland_um"]
        );
        assert_eq!(specs.len(), 8);
        let e =
            design_table("--design full --factors bogus_um=1:2").map(|t| scenarios_from_table(&t));
        assert!(error_chain(&e.unwrap().unwrap_err()).contains("bogus_um"));
    }
}

//! `lgc bench --models`: whole `lgc render` runs of model files, each beside
//! fidget's where its peer binary is given, and a plot of time against the
//! models' operation counts.

use super::super::plot;
use super::figure::TimeFigure;
use anyhow::Context as _;
use lgc::{Formula, Output};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

/// What `--models` runs, and how.
pub struct ModelRuns<'a> {
    pub models: &'a [PathBuf],
    pub bounds: &'a str,
    pub size: u32,
    pub repeat: u32,
    pub threads: usize,
    pub peer: Option<&'a Path>,
    pub plot: Option<&'a Path>,
}

/// One model's figures: its operations and median times in seconds.
pub struct Timed {
    pub name: String,
    pub operations: usize,
    pub lgc: f64,
    /// fidget's best of its JIT and VM, where the peer ran.
    pub peer: Option<f64>,
}

/// The operations of a model: the instructions of its formula's f.
fn operations(path: &Path) -> anyhow::Result<usize> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("cannot read model `{}`", path.display()))?;
    let vm = path.extension().is_some_and(|e| e == "vm");
    let parsed = if vm {
        Formula::parse_vm(&text)
    } else {
        Formula::parse(&text)
    };
    let formula =
        parsed.map_err(|e| anyhow::anyhow!("{}", e.render(&text, &path.display().to_string())))?;
    Ok(formula.tape(&[Output::F]).body().len())
}

/// The median wall time of `repeat` runs of `command`, which must succeed.
fn median_time(mut command: Command, repeat: u32, what: &str) -> anyhow::Result<f64> {
    let mut times = Vec::new();
    for _ in 0..repeat.max(1) {
        let start = Instant::now();
        let out = command
            .output()
            .with_context(|| format!("cannot run {what}"))?;
        times.push(start.elapsed().as_secs_f64());
        if !out.status.success() {
            let err = String::from_utf8_lossy(&out.stderr);
            let last = err.lines().last().unwrap_or("no message");
            anyhow::bail!("{what} failed: {last}");
        }
    }
    times.sort_by(f64::total_cmp);
    Ok(times[times.len() / 2])
}

/// Times every model, prints a row each, and draws the plot.
pub fn run(r: &ModelRuns) -> anyhow::Result<()> {
    let lgc = std::env::current_exe().context("cannot find lgc's own executable")?;
    let scratch = std::env::temp_dir().join(format!("lgc-bench-{}", std::process::id()));
    std::fs::create_dir_all(&scratch).context("cannot make a scratch folder")?;
    let result = time_all(r, &lgc, &scratch);
    let _ = std::fs::remove_dir_all(&scratch);
    let timed = result?;
    if let Some(path) = r.plot {
        let title = format!("render time, {0}x{0}, {1} threads", r.size, r.threads);
        plot::write(
            path,
            "a time plot",
            &TimeFigure {
                title,
                timed: &timed,
            },
        )?;
        println!("plot written to {}", path.display());
    }
    Ok(())
}

fn time_all(r: &ModelRuns, lgc: &Path, scratch: &Path) -> anyhow::Result<Vec<Timed>> {
    // Every model read first: a mistake in one stops the run before any row.
    let counts = r
        .models
        .iter()
        .map(|p| operations(p))
        .collect::<anyhow::Result<Vec<_>>>()?;
    println!(
        "whole process, PNG written, {0}x{0}, {1} thread(s), no shadows, median of {2} run(s)",
        r.size, r.threads, r.repeat
    );
    println!(
        "{:<24} {:>10} {:>10} {:>12} {:>12}",
        "model", "operations", "lgc", "fidget best", "lgc/fidget"
    );
    let mut timed = Vec::new();
    for (path, operations) in r.models.iter().zip(counts) {
        let name = path.file_stem().map_or_else(
            || path.display().to_string(),
            |s| s.to_string_lossy().into_owned(),
        );
        let mut render = Command::new(lgc);
        render
            .arg("render")
            .arg("-f")
            .arg(path)
            .arg("-o")
            .arg(scratch.join("lgc.png"))
            .arg(format!("--size={0}x{0}", r.size))
            .arg(format!("--box={}", r.bounds))
            .arg(format!("--threads={}", r.threads))
            .arg("--no-shadows");
        let lgc_time = median_time(
            render,
            r.repeat,
            &format!("lgc render on `{}`", path.display()),
        )?;
        let peer = match r.peer {
            None => None,
            Some(peer) => {
                let mut best = f64::INFINITY;
                for mode in ["--jit", "--vm"] {
                    let mut run = Command::new(peer);
                    run.arg(format!("@{}", path.display()))
                        .arg(mode)
                        .args(["--threads", &r.threads.to_string()])
                        .args(["--size", &r.size.to_string()])
                        .args(["--reps", "1", "--scale", "1.0", "--out"])
                        .arg(scratch.join("peer.png"));
                    let what = format!("the peer ({mode}) on `{}`", path.display());
                    best = best.min(median_time(run, r.repeat, &what)?);
                }
                Some(best)
            }
        };
        let ratio = peer.map_or_else(|| "-".to_string(), |p| format!("{:.2}", lgc_time / p));
        let peer_text = peer.map_or_else(|| "-".to_string(), |p| format!("{p:.3} s"));
        println!(
            "{name:<24} {operations:>10} {:>8.3} s {peer_text:>12} {ratio:>12}",
            lgc_time
        );
        timed.push(Timed {
            name,
            operations,
            lgc: lgc_time,
            peer,
        });
    }
    Ok(timed)
}

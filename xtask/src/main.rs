//! `cargo xtask`: a thin command line over `bayestrack-eval`.
//!
//! ```text
//! cargo xtask reproduce-table list         # the registry
//! cargo xtask reproduce-table all          # every experiment, quick mode
//! cargo xtask reproduce-table hikpf --full # one experiment at paper scale
//! ```

use std::path::PathBuf;
use std::process::ExitCode;

use bayestrack_eval::experiment::{self, Experiment, Mode, RunOptions};
use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(name = "xtask", about = "bayestrack project tasks")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Print a paper's table beside ours; write CSV and SVG under --out/<id>/.
    ReproduceTable {
        /// `list`, `all`, or an experiment id (see `list`).
        target: String,
        /// Paper scale instead of the quick CI scale.
        #[arg(long)]
        full: bool,
        /// Output root.
        #[arg(long, default_value = "target/reproduce")]
        out: PathBuf,
    },
}

fn print_registry(reg: &[Box<dyn Experiment>]) {
    println!("{:<14} {:<6} {:<52} summary", "id", "state", "source");
    for e in reg {
        let state = if e.implemented() { "ready" } else { "todo" };
        println!(
            "{:<14} {:<6} {:<52} {}",
            e.id(),
            state,
            e.source(),
            e.summary()
        );
    }
}

fn run_one(e: &dyn Experiment, opts: &RunOptions) -> Result<(), experiment::ExperimentError> {
    eprintln!("== {} ({}) ==", e.id(), e.source());
    for table in e.run(opts)? {
        println!("{table}");
    }
    println!("files: {}", opts.out.join(e.id()).display());
    Ok(())
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match cli.command {
        Command::ReproduceTable { target, full, out } => {
            let opts = RunOptions {
                mode: if full { Mode::Full } else { Mode::Quick },
                out,
                progress: true,
            };
            let reg = experiment::registry();
            match target.as_str() {
                "list" => {
                    print_registry(&reg);
                    ExitCode::SUCCESS
                }
                "all" => {
                    let ready: Vec<_> = reg.iter().filter(|e| e.implemented()).collect();
                    if ready.is_empty() {
                        println!("No experiment is implemented yet; registered:");
                        print_registry(&reg);
                        return ExitCode::SUCCESS;
                    }
                    let mut failed = false;
                    for e in &reg {
                        if !e.implemented() {
                            println!("-- {}: not implemented yet ({})\n", e.id(), e.source());
                            continue;
                        }
                        if let Err(err) = run_one(e.as_ref(), &opts) {
                            eprintln!("error: {err}");
                            failed = true;
                        }
                    }
                    if failed {
                        ExitCode::FAILURE
                    } else {
                        ExitCode::SUCCESS
                    }
                }
                id => match experiment::find(id).and_then(|e| run_one(e.as_ref(), &opts)) {
                    Ok(()) => ExitCode::SUCCESS,
                    Err(err) => {
                        eprintln!("error: {err}");
                        ExitCode::FAILURE
                    }
                },
            }
        }
    }
}

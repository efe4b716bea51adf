//! `texgraph check`: parse, check and compile graph files; print a summary (and the tape).

use super::*;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct CheckArgs {
    /// Graph files to check.
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Also print the tape disassembly.
    #[arg(long)]
    tape: bool,
    #[command(flatten)]
    graph: GraphOptions,
}

pub fn check(args: CheckArgs) -> Result<(), Failure> {
    let (check_options, compile_options) = options(&args.graph);
    let mut worst: Option<Failure> = None;
    for file in &args.files {
        match crate::load_tape(file, &check_options, &compile_options) {
            Ok((graph, tape)) => {
                let mut text = crate::summary::check_summary(&graph, &tape);
                if args.tape {
                    text.push_str(&tape.to_string());
                }
                write_stdout(|out| out.write_all(text.as_bytes()))?;
            }
            Err(error) => {
                let failure = print_load_error(error);
                worst = Failure::worst(worst, failure);
            }
        }
    }
    worst.map_or(Ok(()), Err)
}

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
    /// Compile for this region (`X0,Y0,Z0:X1,Y1,Z1` or `unbounded`): precision is chosen per
    /// instruction, and the summary gives each output's error bound.
    #[arg(long, value_name = "X0,Y0,Z0:X1,Y1,Z1", value_parser = parse_extent, allow_hyphen_values = true)]
    extent: Option<crate::precision::Extent>,
    #[command(flatten)]
    graph: GraphOptions,
}

pub fn check(args: CheckArgs) -> Result<(), Failure> {
    let (check_options, mut compile_options) = options(&args.graph);
    compile_options.extent = args.extent;
    let mut worst: Option<Failure> = None;
    for file in &args.files {
        match crate::load::load_tape(file, &check_options, &compile_options) {
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

//! `texgraph verify`: checks a zarr store a bake (or the parts of a split bake) wrote.

use super::*;
#[cfg(feature = "zarr")]
use crate::bake::zarr::{verify_store, ShardState};
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct VerifyArgs {
    /// Zarr stores written by `texgraph bake --format zarr`.
    #[arg(required = true, value_name = "STORE")]
    stores: Vec<PathBuf>,
}

/// Without the `zarr` feature: refused (exit code 2).
#[cfg(not(feature = "zarr"))]
pub fn verify(_: VerifyArgs) -> Result<(), Failure> {
    eprintln!(
        "error: {}",
        crate::diagnostic::without_feature("texgraph verify", "zarr")
    );
    Err(Failure::Usage)
}

/// Exit code 0 when every shard of every store is complete, 1 when any is missing, corrupt or
/// stale (each listed), 2 when a path is not a texgraph zarr store.
#[cfg(feature = "zarr")]
pub fn verify(args: VerifyArgs) -> Result<(), Failure> {
    let mut worst: Option<Failure> = None;
    for store in &args.stores {
        let checks = match verify_store(store) {
            Ok(checks) => checks,
            Err(error) => {
                eprintln!("error: {}: {error}", store.display());
                worst = Failure::worst(worst, Failure::Usage);
                continue;
            }
        };
        let mut text = String::new();
        for check in &checks {
            let complete = check.shards - check.problems.len() as u64;
            text.push_str(&format!(
                "{}/{}: {complete} of {} shards complete\n",
                store.display(),
                check.name,
                check.shards
            ));
            for (key, state) in &check.problems {
                let why = match state {
                    ShardState::Complete => continue,
                    ShardState::Missing => "missing".to_string(),
                    ShardState::NoManifest => {
                        "no manifest (its bake did not finish): re-run the bake to resume".into()
                    }
                    ShardState::Corrupt(why) => format!("corrupt: {why}"),
                    ShardState::Stale(why) => format!("stale: {why}"),
                };
                text.push_str(&format!("  {key}: {why}\n"));
            }
        }
        let missing: usize = checks.iter().map(|c| c.problems.len()).sum();
        if missing > 0 {
            text.push_str(&format!(
                "{}: {missing} shard(s) incomplete; re-run the same bake (every part, or the parts that own them) to complete it\n",
                store.display()
            ));
            worst = Failure::worst(worst, Failure::Invalid);
        }
        write_stdout(|out| out.write_all(text.as_bytes()))?;
    }
    worst.map_or(Ok(()), Err)
}

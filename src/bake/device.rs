//! Which device evaluates a bake's voxels: one decision per tape, [`choose`], taken by every
//! sink (the window engine's formats and mip levels, the zarr shards, the VDB files) and by the
//! command line before it bakes, so they cannot disagree.
//!
//! The rules (docs/gpu.md, "Devices"):
//! - `--device cpu`: the CPU.
//! - `--device gpu`: the GPU, or an error naming why it cannot run this bake: an f64 bake
//!   (`--double`), no usable adapter, a graph its point form or (with `--filter box`) its
//!   filtered form does not cover. Never a silent CPU bake.
//! - `--device auto`: the GPU where it can run the bake, else the CPU with a note saying why
//!   (the command line prints it on stderr, once per graph).

use crate::filter::Filter;
use crate::gpu::{Device, GpuEvaluator};
use crate::tape::Tape;
use std::sync::Arc;

/// What evaluates a bake's voxels.
#[derive(Clone, Debug)]
pub enum Evaluator {
    Cpu,
    /// The GPU's point form (each voxel's value at its centre).
    Gpu(Arc<GpuEvaluator>),
    /// The GPU's filtered form (each voxel's estimated mean over its cell).
    GpuFiltered(Arc<GpuEvaluator>),
}

impl Evaluator {
    /// The device this evaluator runs on (`Cpu` or `Gpu`, never `Auto`).
    pub fn device(&self) -> Device {
        match self {
            Evaluator::Cpu => Device::Cpu,
            Evaluator::Gpu(_) | Evaluator::GpuFiltered(_) => Device::Gpu,
        }
    }

    /// The GPU evaluator, if the bake runs on the GPU.
    pub fn gpu(&self) -> Option<&Arc<GpuEvaluator>> {
        match self {
            Evaluator::Cpu => None,
            Evaluator::Gpu(g) | Evaluator::GpuFiltered(g) => Some(g),
        }
    }
}

/// The decision for one tape: its evaluator, and for `auto` that fell back to the CPU, why.
#[derive(Clone, Debug)]
pub struct Choice {
    pub evaluator: Evaluator,
    pub note: Option<String>,
}

/// Which device bakes `tape` with `filter` (`double`: an f64 bake) when `device` is asked for
/// (see the module documentation). `Err` only for `Device::Gpu`: why the GPU cannot run this
/// bake (the engine's `BakeError::Refused`, which the command line prints with the graph's
/// file).
pub fn choose(tape: &Tape, device: Device, filter: Filter, double: bool) -> Result<Choice, String> {
    let cpu = |note: String| Choice {
        evaluator: Evaluator::Cpu,
        note: Some(note),
    };
    match device {
        Device::Cpu => Ok(Choice {
            evaluator: Evaluator::Cpu,
            note: None,
        }),
        Device::Gpu | Device::Auto if double => {
            let why = "the GPU evaluates the f32 path; an f64 bake (--double) runs on the CPU";
            match device {
                Device::Gpu => Err(format!("--device gpu: {why} (--device cpu)")),
                _ => Ok(cpu(format!("--device auto: {why}"))),
            }
        }
        Device::Gpu | Device::Auto => match gpu_evaluator(tape, filter) {
            Ok(evaluator) => Ok(Choice {
                evaluator,
                note: None,
            }),
            Err(why) if device == Device::Gpu => Err(format!(
                "--device gpu{}: {why} (--device cpu runs it)",
                filter_flag(filter)
            )),
            Err(why) => Ok(cpu(format!(
                "--device auto{}: {why}; baked on the CPU",
                filter_flag(filter)
            ))),
        },
    }
}

/// The GPU's form for `filter`, compiled (and cached) for `tape`, or why it cannot be.
fn gpu_evaluator(tape: &Tape, filter: Filter) -> Result<Evaluator, crate::gpu::GpuError> {
    crate::gpu::usable()?;
    Ok(match filter {
        Filter::Point => Evaluator::Gpu(crate::gpu::evaluator_for(tape)?),
        Filter::Box => Evaluator::GpuFiltered(crate::gpu::filtered_evaluator_for(tape)?),
    })
}

fn filter_flag(filter: Filter) -> &'static str {
    match filter {
        Filter::Point => "",
        Filter::Box => " --filter box",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tape() -> Tape {
        let source = crate::diagnostic::SourceFile::new(
            "t.ron",
            r#"Graph(nodes: { "p": Position }, outputs: { "v": Sin("p.x") })"#,
        );
        let graph = crate::check::check(source, &Default::default()).expect("checks");
        crate::compile::compile(&graph, &Default::default()).expect("compiles")
    }

    /// The CPU is always a choice without a note; an f64 bake is never the GPU's: an error
    /// when the GPU is asked for, a note under `auto`.
    #[test]
    fn the_cpu_and_f64_rules_need_no_gpu() {
        let t = tape();
        for filter in [Filter::Point, Filter::Box] {
            let cpu = choose(&t, Device::Cpu, filter, true).expect("the CPU");
            assert!(matches!(cpu.evaluator, Evaluator::Cpu) && cpu.note.is_none());
            let refused = choose(&t, Device::Gpu, filter, true).expect_err("refused");
            assert!(refused.contains("--double"), "{refused}");
            let auto = choose(&t, Device::Auto, filter, true).expect("auto");
            assert!(matches!(auto.evaluator, Evaluator::Cpu));
            assert!(auto.note.is_some_and(|n| n.contains("f64 bake")));
        }
    }
}

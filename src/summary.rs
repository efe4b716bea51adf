//! The short summary `texgraph check` prints for a graph and its tape.

use crate::graph::CheckedGraph;
use crate::tape::Tape;
use std::fmt::Write;

pub fn check_summary(graph: &CheckedGraph, tape: &Tape) -> String {
    let mut s = String::new();
    let g = graph.stats;
    let _ = writeln!(s, "{}: ok", graph.file.name);
    let _ = writeln!(
        s,
        "  nodes: {} declared, {} written (inline included); {} deduplicated, {} folded; {} after checking, {} live, {} pruned",
        g.declared,
        g.written,
        g.deduplicated,
        g.folded,
        tape.stats.graph_nodes,
        tape.stats.live_nodes,
        tape.stats.pruned_nodes
    );
    let _ = writeln!(
        s,
        "  tape: {} instructions; slots: {} scalar + {} vec3 ({} of them constants)",
        tape.instrs.len(),
        tape.scalar_slots,
        tape.vec3_slots,
        tape.scalar_constants.len() + tape.vec3_constants.len()
    );
    let outputs: Vec<String> = tape
        .outputs
        .iter()
        .map(|o| format!("{} {}", o.name, o.ty))
        .collect();
    let _ = writeln!(s, "  outputs: {}", outputs.join(", "));
    if !graph.imports.is_empty() {
        let files: Vec<String> = graph
            .imports
            .iter()
            .map(|p| p.display().to_string())
            .collect();
        let _ = writeln!(s, "  imports: {}", files.join(", "));
    }
    for (origin, written, kept) in tape.fractal_octaves() {
        if written == kept {
            let _ = writeln!(s, "  fractal \"{origin}\": {kept} octaves kept");
        } else {
            let _ = writeln!(
                s,
                "  fractal \"{origin}\": {kept:.3} of {written} octaves kept (level of detail)"
            );
        }
    }
    if let Some(plan) = tape.precision() {
        precision_summary(&mut s, plan, tape);
    }
    s
}

/// The precision plan's lines: the extent, what was promoted, each output's bounds, and what
/// cannot meet the target and why.
fn precision_summary(s: &mut String, plan: &crate::precision::Plan, tape: &Tape) {
    let _ = writeln!(
        s,
        "  precision: extent {}, max error {:e}; {} of {} instructions in f64",
        plan.extent,
        plan.max_error,
        tape.wide_instructions(),
        tape.instrs.len()
    );
    if let Some(sampled) = plan.sampled {
        let _ = writeln!(
            s,
            "  precision: the bound was within {}x of the target; f32 measured on {} points of the extent: {:.2e}{}",
            crate::precision::CONFIRM_FACTOR,
            crate::precision::SAMPLES,
            sampled,
            if tape.wide_instructions() == 0 { " (plain tape kept)" } else { "" }
        );
    }
    for o in &plan.outputs {
        let _ = writeln!(
            s,
            "  output \"{}\": error bound {:.2e} (all f32: {:.2e}; f64 itself: {:.2e})",
            o.output, o.promoted, o.plain_f32, o.f64_floor
        );
        if let Some(why) = &o.shortfall {
            let _ = writeln!(
                s,
                "  warning: {}",
                crate::tape::shortfall_text(&o.output, plan.max_error, why)
            );
        }
    }
}

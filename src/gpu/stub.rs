//! [`GpuEvaluator`] in a build without the `gpu` feature: it cannot be made (`new` says why),
//! so every caller takes its CPU path.

use super::error::GpuError;
use crate::tape::Tape;

/// Never constructed without the `gpu` feature.
#[derive(Debug)]
pub struct GpuEvaluator {
    never: std::convert::Infallible,
}

impl GpuEvaluator {
    pub fn new(_tape: &Tape) -> Result<GpuEvaluator, GpuError> {
        Err(GpuError::NoAdapter(
            "this texgraph was built without the `gpu` cargo feature".into(),
        ))
    }

    pub fn new_filtered(_tape: &Tape) -> Result<GpuEvaluator, GpuError> {
        GpuEvaluator::new(_tape)
    }

    pub fn eval_batch_filtered(
        &self,
        _points: [&[f64]; 3],
        _footprints: &[crate::filter::Footprint],
        _out: &mut [f32],
    ) -> Result<(), GpuError> {
        match self.never {}
    }

    pub(super) fn new_unavailable() -> Result<String, GpuError> {
        Err(GpuError::NoAdapter(
            "this texgraph was built without the `gpu` cargo feature".into(),
        ))
    }

    pub fn adapter(&self) -> String {
        match self.never {}
    }

    pub fn channels(&self) -> usize {
        match self.never {}
    }

    pub fn is_software(&self) -> bool {
        match self.never {}
    }

    pub fn eval_batch(
        &self,
        _x: &[f64],
        _y: &[f64],
        _z: &[f64],
        _out: &mut [f32],
    ) -> Result<(), GpuError> {
        match self.never {}
    }

    pub fn eval_batch_lod(
        &self,
        _points: [&[f64]; 3],
        _spacing: &[f64],
        _out: &mut [f32],
    ) -> Result<(), GpuError> {
        match self.never {}
    }

    pub fn eval_grid(&self, _grid: &crate::grid::Grid, _keep: bool) -> Result<(), GpuError> {
        match self.never {}
    }

    pub fn bake_window(
        &self,
        _grid: &crate::grid::Grid,
        _layout: &crate::grid::Layout,
        _first: u64,
        _data: &mut [f32],
    ) -> Result<(), GpuError> {
        match self.never {}
    }
}

/// Never constructed without the `gpu` feature.
pub struct GpuBake {
    never: std::convert::Infallible,
}

impl GpuBake {
    pub fn new(
        evaluator: std::sync::Arc<GpuEvaluator>,
        _grid: &crate::grid::Grid,
        _layout: &crate::grid::Layout,
        _packing: crate::encoding::Packing,
    ) -> Result<GpuBake, GpuError> {
        match evaluator.never {}
    }

    pub fn queued(&self) -> usize {
        match self.never {}
    }

    pub fn submit(&mut self, _first: u64, _count: usize) -> Result<(), GpuError> {
        match self.never {}
    }

    pub fn for_each_window(
        &mut self,
        _each: impl FnMut(u64, usize, &[u8], Vec<super::window_stats::WindowStats>),
    ) -> Result<(), GpuError> {
        match self.never {}
    }

    pub fn collect(
        &mut self,
        _out: &mut Vec<u8>,
    ) -> Result<Vec<super::window_stats::WindowStats>, GpuError> {
        match self.never {}
    }
}

//! The voxel grid and how a bake cuts it: [`Region`] and [`Grid`] (the voxel centres), the
//! [`Layout`] of segments and windows. The bake engine, the zarr and VDB writers and the GPU
//! evaluator all stand on it; it stands on nothing of texgraph's.

/// The box the grid covers. Default: the unit cube [0, 1]³.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct Region {
    pub min: [f64; 3],
    pub max: [f64; 3],
}

impl Default for Region {
    fn default() -> Self {
        Region {
            min: [0.0; 3],
            max: [1.0; 3],
        }
    }
}

/// A voxel grid: `size` voxels along x, y, z over `region`. Voxel (i, j, k) samples the centre of
/// its cell: `region.min + (index + 0.5) · (region.max − region.min) / size`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Grid {
    pub size: [usize; 3],
    pub region: Region,
}

impl Grid {
    pub fn cube(n: usize) -> Grid {
        Grid {
            size: [n; 3],
            region: Region::default(),
        }
    }

    /// Total voxels; `None` if the count overflows u64.
    pub fn voxels(&self) -> Option<u64> {
        self.size
            .iter()
            .try_fold(1u64, |acc, &n| acc.checked_mul(n as u64))
    }

    /// The centre coordinate of voxel `index` along `axis`.
    #[inline]
    pub fn centre(&self, axis: usize, index: usize) -> f64 {
        let (lo, hi) = (self.region.min[axis], self.region.max[axis]);
        lo + (index as f64 + 0.5) * (hi - lo) / self.size[axis] as f64
    }

    /// The spacing between voxel centres along each axis.
    pub fn spacing(&self) -> [f64; 3] {
        [0, 1, 2].map(|a| (self.region.max[a] - self.region.min[a]) / self.size[a] as f64)
    }
}

/// Longest run of voxels one task evaluates (rows longer than this are split).
pub const SEGMENT_VOXELS: usize = 64 * 1024;
/// Bound on one segment's evaluated samples (channels × voxels × 8 bytes): a graph with many
/// outputs gets shorter segments.
pub const SEGMENT_BYTES: usize = 4 << 20;
/// Bound on a window's samples (channels × voxels × 4 bytes), unless one segment is larger. A
/// bake holds two windows (one evaluated while the other is written): 2 × this.
pub const WINDOW_BYTES: usize = 64 << 20;

/// How a grid is cut into segments and windows; depends on the grid, the channel count and the
/// thread count (windows only: segments never depend on threads).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Layout {
    /// Voxels per segment (the last segment of a row may be shorter).
    pub segment_len: usize,
    /// Segments per row of voxels.
    pub per_row: usize,
    /// Segments in the grid.
    pub total: u64,
    /// Segments per window (the last window may hold fewer).
    pub per_window: usize,
}

impl Layout {
    /// The layout of `grid` for `channels` channels and `threads` worker threads. `None` for an
    /// empty grid or no channels.
    pub fn new(grid: &Grid, channels: usize, threads: usize) -> Option<Layout> {
        let [nx, ny, nz] = grid.size;
        if nx == 0 || ny == 0 || nz == 0 || channels == 0 {
            return None;
        }
        let segment_len = nx
            .min(SEGMENT_VOXELS)
            .min((SEGMENT_BYTES / (8 * channels)).max(1));
        let per_row = nx.div_ceil(segment_len);
        let slice = (per_row as u64).checked_mul(ny as u64)?;
        let total = slice.checked_mul(nz as u64)?;
        // About two full segments' worth of voxels per thread, within the window's byte bound.
        let by_threads = 2 * threads.max(1) * SEGMENT_VOXELS;
        let by_bytes = WINDOW_BYTES / (4 * channels);
        let target = (by_threads.min(by_bytes) / segment_len).max(1) as u64;
        // Small slices: whole slices per window (sinks write them in parallel).
        let per_window = if slice <= target {
            (target / slice) * slice
        } else {
            target
        };
        Some(Layout {
            segment_len,
            per_row,
            total,
            per_window: per_window.min(total) as usize,
        })
    }

    /// How many voxels come before segment `index` in file order (the whole grid for
    /// `index == total`).
    pub fn voxels_before(&self, grid: &Grid, index: u64) -> u64 {
        let nx = grid.size[0] as u64;
        let (rows, part) = (index / self.per_row as u64, index % self.per_row as u64);
        rows * nx + (part * self.segment_len as u64).min(nx)
    }

    /// Where segment `index` of the grid lies.
    #[inline]
    pub fn segment(&self, grid: &Grid, index: u64) -> Segment {
        let [nx, ny, _] = grid.size;
        let row = index / self.per_row as u64;
        let part = (index % self.per_row as u64) as usize;
        let i0 = part * self.segment_len;
        Segment {
            k: (row / ny as u64) as usize,
            j: (row % ny as u64) as usize,
            i0,
            len: self.segment_len.min(nx - i0),
        }
    }
}

/// A run of voxels inside one row: voxels (i0 .. i0 + len, j, k).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Segment {
    pub k: usize,
    pub j: usize,
    pub i0: usize,
    pub len: usize,
}

impl Segment {
    /// The segment starts a z slice.
    pub fn starts_slice(&self) -> bool {
        self.i0 == 0 && self.j == 0
    }

    /// The segment ends its z slice.
    pub fn ends_slice(&self, grid: &Grid) -> bool {
        self.i0 + self.len == grid.size[0] && self.j + 1 == grid.size[1]
    }
}

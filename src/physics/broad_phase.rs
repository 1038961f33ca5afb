//! Broad phase: a uniform grid that finds the pairs of balls that may touch in O(n).
//!
//! The cell is as wide as the largest "small" ball, so two touching small balls always lie in the
//! same or neighbouring cells. Balls much larger than the typical one (more than
//! [`BIG_BALL_FACTOR`] times the median diameter) would make every cell huge; they are kept out of
//! the grid and each is checked against the cells its bounding box covers. Cells are filled by a
//! counting sort each step, so building the grid allocates nothing once warm and the pair order
//! is a pure function of the positions: deterministic.

use glam::DVec2;

/// A ball is "big" when its diameter exceeds this many median diameters.
pub const BIG_BALL_FACTOR: f64 = 4.0;

/// The grid and its scratch memory. Rebuild with [`BroadPhase::update`] every step.
#[derive(Clone, Debug, Default)]
pub struct BroadPhase {
    cell: f64,
    inverse_cell: f64,
    cols: usize,
    rows: usize,
    /// Indices of the balls kept out of the grid.
    big: Vec<u32>,
    is_big: Vec<bool>,
    cell_of: Vec<u32>,
    /// `cell_start[c]..cell_start[c + 1]` indexes `entries` for cell c.
    cell_start: Vec<u32>,
    entries: Vec<u32>,
    /// `(x, y, radius)` of `entries[k]`, copied so the pair loops read memory in order.
    entry_shape: Vec<[f64; 3]>,
    /// The radii the layout was chosen for (compared whole each step: a sum or a count would miss
    /// a big ball removed and another added elsewhere).
    layout_radii: Vec<f64>,
    layout_field: (f64, f64),
    /// Occupied cells of the last update, in row-major order (the pair search visits only these).
    occupied: Vec<u32>,
}

impl BroadPhase {
    pub fn new() -> Self {
        Self::default()
    }

    /// Cell width in metres (for diagnostics).
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// Chooses the cell size and the big balls. Cheap to call every step: it recomputes only when
    /// the set of diameters changed.
    fn layout(&mut self, radii: &[f64], width: f64, height: f64) {
        if self.cols > 0 && self.layout_field == (width, height) && self.layout_radii == radii {
            return;
        }
        self.layout_field = (width, height);
        self.layout_radii.clear();
        self.layout_radii.extend_from_slice(radii);
        let n = radii.len();
        let mut sorted: Vec<f64> = radii.to_vec();
        sorted.sort_by(f64::total_cmp);
        let median_d = if n == 0 { 1.0 } else { 2.0 * sorted[n / 2] };
        let limit = BIG_BALL_FACTOR * median_d;
        self.is_big.clear();
        self.big.clear();
        let mut cell = 0.0f64;
        for (i, r) in radii.iter().enumerate() {
            let big = 2.0 * r > limit;
            self.is_big.push(big);
            if big {
                self.big.push(i as u32);
            } else {
                cell = cell.max(2.0 * r);
            }
        }
        // Never more cells than about four per ball: tiny balls in a big field get larger cells
        // (still correct, only less selective).
        let max_cells = (4 * n + 64) as f64;
        let min_cell = (width * height / max_cells).sqrt();
        self.cell = cell.max(min_cell).max(f64::MIN_POSITIVE);
        self.inverse_cell = 1.0 / self.cell;
        self.cols = ((width / self.cell).ceil() as usize).max(1);
        self.rows = ((height / self.cell).ceil() as usize).max(1);
    }

    #[inline]
    fn cell_coords(&self, p: DVec2) -> (usize, usize) {
        // `as usize` saturates: NaN and negatives go to 0, huge values are clamped below.
        let cx = ((p.x * self.inverse_cell) as usize).min(self.cols - 1);
        let cy = ((p.y * self.inverse_cell) as usize).min(self.rows - 1);
        (cx, cy)
    }

    /// Sorts the balls into cells for the positions given.
    pub fn update(&mut self, positions: &[DVec2], radii: &[f64], width: f64, height: f64) {
        self.layout(radii, width, height);
        let cells = self.cols * self.rows;
        self.cell_start.clear();
        self.cell_start.resize(cells + 1, 0);
        self.cell_of.clear();
        for (i, p) in positions.iter().enumerate() {
            if self.is_big[i] {
                self.cell_of.push(u32::MAX);
                continue;
            }
            let (cx, cy) = self.cell_coords(*p);
            let c = cy * self.cols + cx;
            self.cell_of.push(c as u32);
            self.cell_start[c + 1] += 1;
        }
        self.occupied.clear();
        for c in 0..cells {
            if self.cell_start[c + 1] != 0 {
                self.occupied.push(c as u32);
            }
            self.cell_start[c + 1] += self.cell_start[c];
        }
        let total = self.cell_start[cells] as usize;
        self.entries.clear();
        self.entries.resize(total, 0);
        self.entry_shape.clear();
        self.entry_shape.resize(total, [0.0; 3]);
        // Fill using the starts as cursors, then restore them by shifting back one cell.
        for (i, &c) in self.cell_of.iter().enumerate() {
            if c == u32::MAX {
                continue;
            }
            let slot = &mut self.cell_start[c as usize];
            self.entries[*slot as usize] = i as u32;
            self.entry_shape[*slot as usize] = [positions[i].x, positions[i].y, radii[i]];
            *slot += 1;
        }
        for c in (1..=cells).rev() {
            self.cell_start[c] = self.cell_start[c - 1];
        }
        self.cell_start[0] = 0;
    }

    #[inline]
    fn cell_range(&self, c: usize) -> std::ops::Range<usize> {
        self.cell_start[c] as usize..self.cell_start[c + 1] as usize
    }

    /// Calls `f(i, j)` once for every pair of balls that overlap (centres closer than the sum of
    /// the radii) at the positions given to the last [`BroadPhase::update`]. The order is
    /// deterministic: cells in row-major order, then the order of the balls within them.
    pub fn for_each_touching_pair<F: FnMut(usize, usize)>(&self, positions: &[DVec2], radii: &[f64], mut f: F) {
        let (cols, rows) = (self.cols, self.rows);
        let shape = &self.entry_shape;
        let entries = &self.entries;
        #[inline(always)]
        fn touching(a: &[f64; 3], b: &[f64; 3]) -> bool {
            let (dx, dy, reach) = (b[0] - a[0], b[1] - a[1], a[2] + b[2]);
            dx * dx + dy * dy < reach * reach
        }
        for &c in &self.occupied {
            let c = c as usize;
            let (cx, cy) = (c % cols, c / cols);
            {
                let here = self.cell_range(c);
                // Half stencil: this cell, then E, NW, N, NE, so each neighbouring pair of cells
                // is visited from one side only.
                for k in here.clone() {
                    for m in (k + 1)..here.end {
                        if touching(&shape[k], &shape[m]) {
                            f(entries[k] as usize, entries[m] as usize);
                        }
                    }
                }
                let right = cx + 1 < cols;
                let up = cy + 1 < rows;
                let mut neighbours = [usize::MAX; 4];
                if right {
                    neighbours[0] = c + 1;
                }
                if up {
                    if cx > 0 {
                        neighbours[1] = c + cols - 1;
                    }
                    neighbours[2] = c + cols;
                    if right {
                        neighbours[3] = c + cols + 1;
                    }
                }
                for nc in neighbours {
                    if nc == usize::MAX {
                        continue;
                    }
                    let there = self.cell_range(nc);
                    for k in here.clone() {
                        for m in there.clone() {
                            if touching(&shape[k], &shape[m]) {
                                f(entries[k] as usize, entries[m] as usize);
                            }
                        }
                    }
                }
            }
        }
        // Big balls: against each other directly, and against the small balls in the cells their
        // bounding box (grown by one cell) covers.
        let shape_of = |i: usize| [positions[i].x, positions[i].y, radii[i]];
        for (k, &a) in self.big.iter().enumerate() {
            let sa = shape_of(a as usize);
            for &b in &self.big[k + 1..] {
                if touching(&sa, &shape_of(b as usize)) {
                    f(a as usize, b as usize);
                }
            }
            let p = positions[a as usize];
            let reach = radii[a as usize] + self.cell;
            let (x0, y0) = self.cell_coords(p - DVec2::splat(reach));
            let (x1, y1) = self.cell_coords(p + DVec2::splat(reach));
            for cy in y0..=y1 {
                for cx in x0..=x1 {
                    for m in self.cell_range(cy * cols + cx) {
                        if touching(&sa, &shape[m]) {
                            f(a as usize, entries[m] as usize);
                        }
                    }
                }
            }
        }
    }
}

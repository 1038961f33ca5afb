//! The cell list: a uniform grid over the field whose cells are at least as wide as the largest
//! ball, so that two balls that touch have their centres in the same or in adjacent cells.
//!
//! A ball belongs to the cell its centre was in when it last crossed a cell boundary (a
//! cell-crossing event), not to the one its centre is in now: the grid changes only at events.
//! Rounding can put a centre a hair outside its cell, which the margin on the cell size absorbs
//! (cells are wider than the largest diameter by one part in 10⁶).

use glam::DVec2;

/// The grid and which balls are in each cell.
#[derive(Clone, Debug, Default)]
pub struct Cells {
    /// Cells across.
    pub nx: usize,
    /// Cells up.
    pub ny: usize,
    /// Cell width and height, m.
    pub size: DVec2,
    /// Ball indices per cell, row-major (`cx + nx·cy`).
    members: Vec<Vec<u32>>,
    /// Each ball's cell.
    cell_of: Vec<u32>,
}

/// Cells per ball at most: beyond that a sparse field pays in empty cells scanned and crossings,
/// not in pairs tested.
const MAX_CELLS_PER_BALL: usize = 4;

impl Cells {
    /// A grid over a `width` × `height` field for `balls` balls of largest diameter `largest`.
    pub fn new(width: f64, height: f64, largest: f64, balls: usize) -> Cells {
        let reach = (largest * (1.0 + 1e-6)).max(f64::MIN_POSITIVE);
        let mut nx = ((width / reach).floor() as usize).max(1);
        let mut ny = ((height / reach).floor() as usize).max(1);
        let cap = MAX_CELLS_PER_BALL * balls.max(1) + 16;
        while nx * ny > cap {
            nx = nx.div_ceil(2);
            ny = ny.div_ceil(2);
        }
        Cells {
            nx,
            ny,
            size: DVec2::new(width / nx as f64, height / ny as f64),
            members: vec![Vec::new(); nx * ny],
            cell_of: Vec::new(),
        }
    }

    /// The cell a point is in, clamped to the grid.
    pub fn locate(&self, p: DVec2) -> (usize, usize) {
        let cx = (p.x / self.size.x).floor().clamp(0.0, (self.nx - 1) as f64) as usize;
        let cy = (p.y / self.size.y).floor().clamp(0.0, (self.ny - 1) as f64) as usize;
        (cx, cy)
    }

    /// Puts every ball into the cell of its position.
    pub fn fill(&mut self, positions: impl Iterator<Item = DVec2>) {
        for m in &mut self.members {
            m.clear();
        }
        self.cell_of.clear();
        for (i, p) in positions.enumerate() {
            let (cx, cy) = self.locate(p);
            let c = cx + self.nx * cy;
            self.members[c].push(i as u32);
            self.cell_of.push(c as u32);
        }
    }

    /// Ball `i`'s cell, `(column, row)`.
    pub fn cell_of(&self, i: usize) -> (usize, usize) {
        let c = self.cell_of[i] as usize;
        (c % self.nx, c / self.nx)
    }

    /// The boundaries of ball `i`'s cell, `[x_lo, x_hi, y_lo, y_hi]`; infinite where the cell is
    /// at the edge of the grid (a ball cannot leave the field).
    pub fn bounds(&self, i: usize) -> [f64; 4] {
        let (cx, cy) = self.cell_of(i);
        let lo = |k: usize, s: f64| if k == 0 { f64::NEG_INFINITY } else { k as f64 * s };
        let hi = |k: usize, n: usize, s: f64| if k + 1 == n { f64::INFINITY } else { (k + 1) as f64 * s };
        [lo(cx, self.size.x), hi(cx, self.nx, self.size.x), lo(cy, self.size.y), hi(cy, self.ny, self.size.y)]
    }

    /// Moves ball `i` one cell over, across boundary `side` (0 −x, 1 +x, 2 −y, 3 +y).
    pub fn cross(&mut self, i: usize, side: u8) {
        let (cx, cy) = self.cell_of(i);
        let (nx, ny) = match side {
            0 => (cx.saturating_sub(1), cy),
            1 => ((cx + 1).min(self.nx - 1), cy),
            2 => (cx, cy.saturating_sub(1)),
            _ => (cx, (cy + 1).min(self.ny - 1)),
        };
        self.move_to(i, nx + self.nx * ny);
    }

    fn move_to(&mut self, i: usize, c: usize) {
        let old = self.cell_of[i] as usize;
        if old == c {
            return;
        }
        let m = &mut self.members[old];
        if let Some(k) = m.iter().position(|&b| b as usize == i) {
            m.swap_remove(k);
        }
        self.members[c].push(i as u32);
        self.cell_of[i] = c as u32;
    }

    /// Calls `f` with every ball in the three cells that joined ball `i`'s 3 × 3 block when it
    /// crossed into its cell across `side` (as [`Cells::cross`] takes it): the column or row
    /// beyond its new cell, if the grid has one.
    #[inline]
    pub fn for_each_joined(&self, i: usize, side: u8, mut f: impl FnMut(usize)) {
        let (cx, cy) = self.cell_of(i);
        let (xs, ys) = match side {
            0 if cx > 0 => ((cx - 1, cx - 1), (cy.saturating_sub(1), (cy + 1).min(self.ny - 1))),
            1 if cx + 1 < self.nx => ((cx + 1, cx + 1), (cy.saturating_sub(1), (cy + 1).min(self.ny - 1))),
            2 if cy > 0 => ((cx.saturating_sub(1), (cx + 1).min(self.nx - 1)), (cy - 1, cy - 1)),
            3 if cy + 1 < self.ny => ((cx.saturating_sub(1), (cx + 1).min(self.nx - 1)), (cy + 1, cy + 1)),
            _ => return,
        };
        for y in ys.0..=ys.1 {
            for x in xs.0..=xs.1 {
                for &j in &self.members[x + self.nx * y] {
                    f(j as usize);
                }
            }
        }
    }

    /// Calls `f` with every ball in the 3 × 3 block of cells around ball `i`'s (`i` included).
    #[inline]
    pub fn for_each_near(&self, i: usize, mut f: impl FnMut(usize)) {
        let (cx, cy) = self.cell_of(i);
        let (x0, x1) = (cx.saturating_sub(1), (cx + 1).min(self.nx - 1));
        let (y0, y1) = (cy.saturating_sub(1), (cy + 1).min(self.ny - 1));
        for y in y0..=y1 {
            let row = y * self.nx;
            for x in x0..=x1 {
                for &j in &self.members[row + x] {
                    f(j as usize);
                }
            }
        }
    }
}

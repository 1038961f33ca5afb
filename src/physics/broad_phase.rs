//! Broad phase: a uniform grid that finds the pairs of balls that may touch in O(n).
//!
//! The cell is as wide as the largest "small" ball (or wider in a sparse field, so that there are
//! about as many cells as balls), so two touching small balls always lie in the same or
//! neighbouring cells. Balls much larger than the typical one (more than [`BIG_BALL_FACTOR`]
//! times the median diameter) would make every cell huge; they are kept out of the grid and each
//! is checked against the cells its bounding box covers. Cells are filled by a counting sort each
//! step, so building the grid allocates nothing once warm and the pair order is a pure function
//! of the positions: deterministic.
//!
//! **Slots.** The sort puts the balls in *slot* order: the balls of cell 0, of cell 1, … in
//! row-major order, then the big balls. [`BroadPhase::slots`] maps a slot to its ball. Pairs are
//! reported as slots, so a solver can work on a copy of the balls in slot order.
//!
//! **Bands.** The rows are grouped into horizontal *bands* of at least [`MIN_BAND_ROWS`] rows
//! (at most [`MAX_BANDS`] bands), chosen from the grid alone. A band's balls are a contiguous run
//! of slots. Every touching pair is one of three kinds:
//! - *inside band b*: both balls in band b ([`BroadPhase::for_each_band_pair`]);
//! - *on seam b*: one ball in the top row of band b, one in the bottom row of band b + 1
//!   ([`BroadPhase::for_each_seam_pair`]); a seam's balls are a contiguous run of slots too, and
//!   since bands have at least two rows, two seams never share a ball;
//! - *with a big ball* ([`BroadPhase::for_each_big_pair`]).
//!
//! So the pairs of different bands touch disjoint balls, and so do the pairs of different seams:
//! a solver may work the bands at the same time, then the seams, then the big balls, and get the
//! same bits however many threads share the work (the lockstep engine does exactly this).

use std::ops::Range;

/// A ball is "big" when its diameter exceeds this many median diameters.
pub const BIG_BALL_FACTOR: f64 = 4.0;
/// Fewest grid rows in a band (at least 2: see the module comment).
pub const MIN_BAND_ROWS: usize = 4;
/// Most bands the rows are grouped into.
pub const MAX_BANDS: usize = 64;

/// The grid and its scratch memory. Rebuild with [`BroadPhase::update`] every step.
#[derive(Clone, Debug, Default)]
pub struct BroadPhase {
    cell: f64,
    inverse_cell: f64,
    cols: usize,
    rows: usize,
    /// Rows per band (the last band may have fewer) and the number of bands.
    band_rows: usize,
    bands: usize,
    /// Indices of the balls kept out of the grid.
    big: Vec<u32>,
    is_big: Vec<bool>,
    cell_of: Vec<u32>,
    /// `cell_start[c]..cell_start[c + 1]` are the slots of cell c (length cells + 1).
    cell_start: Vec<u32>,
    /// The ball in each slot: grid balls in cell order, then the big balls.
    slots: Vec<u32>,
    /// The slot of each ball (the inverse of `slots`).
    ball_slot: Vec<u32>,
    /// `(x, y, radius)` of each slot's ball, copied so the pair loops read memory in order.
    slot_shape: Vec<[f64; 3]>,
    /// The radii the layout was chosen for (compared whole each step: a sum or a count would miss
    /// a big ball removed and another added elsewhere).
    layout_radii: Vec<f64>,
    /// Scratch of the median diameter's selection in [`BroadPhase::layout`].
    median_scratch: Vec<f64>,
    layout_field: (f64, f64),
    layout_margin: (f64, f64),
    /// Occupied cells of the last update, in row-major order (the pair search visits only these).
    occupied: Vec<u32>,
    /// Relative growth of every radius for the pair test (0: strictly overlapping pairs only).
    margin: f64,
    /// The skin as a fraction of the median diameter, and in metres (see
    /// [`BroadPhase::set_skin`]).
    skin_fraction: f64,
    skin: f64,
    /// `occupied[band_occupied[b]..band_occupied[b + 1]]` are the occupied cells of band b.
    band_occupied: Vec<u32>,
}

/// Writes each ball's cell to `cell_of` (`u32::MAX` for a big ball) and counts the balls of
/// cell c in `counts[c]`. (Free functions with slice arguments, so the compiler knows the
/// slices do not alias and keeps the loop tight.)
fn count_cells(
    positions: &[glam::DVec2],
    is_big: &[bool],
    cell_of: &mut [u32],
    counts: &mut [u32],
    cell: impl Fn(f64, f64) -> usize,
) {
    for ((p, &big), slot) in positions.iter().zip(is_big).zip(cell_of.iter_mut()) {
        if big {
            *slot = u32::MAX;
        } else {
            let c = cell(p.x, p.y);
            *slot = c as u32;
            counts[c] += 1;
        }
    }
}

/// Puts each grid ball into the next free slot of its cell (`cursor[c]`, advanced).
#[allow(clippy::too_many_arguments)]
fn fill_slots(
    positions: &[glam::DVec2],
    radii: &[f64],
    (grow, skin): (f64, f64),
    cell_of: &[u32],
    cursor: &mut [u32],
    slots: &mut [u32],
    ball_slot: &mut [u32],
    shape: &mut [[f64; 3]],
) {
    for (i, &c) in cell_of.iter().enumerate() {
        if c == u32::MAX {
            continue;
        }
        let slot = cursor[c as usize] as usize;
        cursor[c as usize] += 1;
        slots[slot] = i as u32;
        ball_slot[i] = slot as u32;
        shape[slot] = [positions[i].x, positions[i].y, radii[i] * grow + skin];
    }
}

/// Whether two `(x, y, radius)` shapes overlap; radii are stored grown by the margin and half the
/// skin (see [`BroadPhase::set_margin`], [`BroadPhase::set_skin`]).
#[inline(always)]
fn touching(a: &[f64; 3], b: &[f64; 3]) -> bool {
    let (dx, dy, reach) = (b[0] - a[0], b[1] - a[1], a[2] + b[2]);
    dx * dx + dy * dy < reach * reach
}

impl BroadPhase {
    /// An empty broad phase with no margin and no skin; it allocates on its first update and
    /// reuses that memory afterwards.
    pub fn new() -> Self {
        Self::default()
    }

    /// Also report pairs that are within `margin` (relative to the sum of their radii) of
    /// touching, e.g. 1e-6 to catch pairs a solver left exactly touching. Takes effect at the
    /// next update. Grows the radii used for the pair test by that factor.
    pub fn set_margin(&mut self, margin: f64) {
        self.margin = margin.max(0.0);
    }

    /// Also report pairs up to a *skin* apart, `skin_fraction` of the median diameter, so that
    /// the pairs stay a complete list of the touching ones until some ball has moved half the
    /// skin (a Verlet list): a caller may then skip the search for steps in between.
    pub fn set_skin(&mut self, skin_fraction: f64) {
        self.skin_fraction = skin_fraction.max(0.0);
    }

    /// The skin in metres (after an update).
    pub fn skin(&self) -> f64 {
        self.skin
    }

    /// Cell width in metres (for diagnostics).
    pub fn cell_size(&self) -> f64 {
        self.cell
    }

    /// Chooses the cell size, the bands and the big balls. Cheap to call every step: it
    /// recomputes only when the set of diameters or the field changed.
    fn layout(&mut self, radii: &[f64], width: f64, height: f64) {
        if self.cols > 0
            && self.layout_field == (width, height)
            && self.layout_radii == radii
            && self.layout_margin == (self.margin, self.skin_fraction)
        {
            return;
        }
        self.layout_field = (width, height);
        self.layout_margin = (self.margin, self.skin_fraction);
        self.layout_radii.clear();
        self.layout_radii.extend_from_slice(radii);
        let n = radii.len();
        // The median by selection, not a sort: the same element (the order is total), and the
        // threaded monitor's radii (its swept circles) change every pass, so this runs every
        // pass there (a full sort was 1.6 % of its settling pass).
        let median_d = if n == 0 {
            1.0
        } else {
            let mut scratch = std::mem::take(&mut self.median_scratch);
            scratch.clear();
            scratch.extend_from_slice(radii);
            let (_, median, _) = scratch.select_nth_unstable_by(n / 2, f64::total_cmp);
            let median = 2.0 * *median;
            self.median_scratch = scratch;
            median
        };
        let limit = BIG_BALL_FACTOR * median_d;
        self.skin = self.skin_fraction * median_d;
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
        // About one cell per ball at most: in a sparse field the cells grow (still correct, only
        // less selective), which keeps the per-step sweep over the cells as cheap as the balls.
        let max_cells = (n + 16) as f64;
        let min_cell = (width * height / max_cells).sqrt();
        self.cell = (cell * (1.0 + self.margin) + self.skin).max(min_cell).max(f64::MIN_POSITIVE);
        // A field much longer than it is wide has a row or column however large the cells (the
        // counts round up to 1), and min_cell alone leaves cols·rows up to the long side over
        // the cell: then the cells are also at least the long side over max_cells. Where the
        // counts are within 4·max_cells (any field whose sides are both at most max_cells cells
        // long: at most 3·max_cells + 1), the cell is as it always was.
        if (width / self.cell).ceil() * (height / self.cell).ceil() > 4.0 * max_cells {
            self.cell = self.cell.max(width.max(height) / max_cells);
        }
        self.inverse_cell = 1.0 / self.cell;
        self.cols = ((width / self.cell).ceil() as usize).max(1);
        self.rows = ((height / self.cell).ceil() as usize).max(1);
        self.band_rows = MIN_BAND_ROWS.max(self.rows.div_ceil(MAX_BANDS));
        self.bands = self.rows.div_ceil(self.band_rows);
    }

    #[inline]
    fn cell_of_point(&self, x: f64, y: f64) -> usize {
        // `as usize` saturates: NaN and negatives go to 0, huge values are clamped below.
        let cx = ((x * self.inverse_cell) as usize).min(self.cols - 1);
        let cy = ((y * self.inverse_cell) as usize).min(self.rows - 1);
        cy * self.cols + cx
    }

    /// Sorts the balls into cells (and slots) for the positions given.
    pub fn update(&mut self, positions: &[glam::DVec2], radii: &[f64], width: f64, height: f64) {
        self.layout(radii, width, height);
        let cells = self.cols * self.rows;
        // Count the balls of each cell in cell_start[c + 1].
        let mut start = std::mem::take(&mut self.cell_start);
        start.clear();
        start.resize(cells + 1, 0);
        self.cell_of.resize(positions.len(), 0);
        let (cols, rows, inverse_cell) = (self.cols, self.rows, self.inverse_cell);
        count_cells(positions, &self.is_big, &mut self.cell_of, &mut start[1..], |x, y| {
            // `as usize` saturates: NaN and negatives go to 0, huge values are clamped below.
            let cx = ((x * inverse_cell) as usize).min(cols - 1);
            let cy = ((y * inverse_cell) as usize).min(rows - 1);
            cy * cols + cx
        });
        // Prefix sums: start[c] becomes the first slot of cell c.
        let mut occupied = std::mem::take(&mut self.occupied);
        occupied.clear();
        let mut sum = 0u32;
        for c in 0..cells {
            let count = start[c + 1];
            start[c] = sum;
            if count != 0 {
                occupied.push(c as u32);
            }
            sum += count;
        }
        start[cells] = sum;
        let grid = sum as usize;
        let total = grid + self.big.len();
        self.slots.resize(total, 0);
        self.slot_shape.resize(total, [0.0; 3]);
        // Fill, using start[c] as cell c's cursor; afterwards start[c] is the end of cell c,
        // which is the start of cell c + 1: shift back by one cell.
        self.ball_slot.resize(positions.len(), 0);
        let (grow, skin) = (1.0 + self.margin, 0.5 * self.skin);
        fill_slots(
            positions,
            radii,
            (grow, skin),
            &self.cell_of,
            &mut start,
            &mut self.slots,
            &mut self.ball_slot,
            &mut self.slot_shape,
        );
        start.copy_within(0..cells, 1);
        start[0] = 0;
        for (k, &b) in self.big.iter().enumerate() {
            self.slots[grid + k] = b;
            self.ball_slot[b as usize] = (grid + k) as u32;
            self.slot_shape[grid + k] =
                [positions[b as usize].x, positions[b as usize].y, radii[b as usize] * grow + skin];
        }
        // The occupied cells of each band.
        self.band_occupied.clear();
        let mut k = 0;
        for b in 0..self.bands {
            self.band_occupied.push(k as u32);
            let end = (self.band_row_range(b).end * self.cols) as u32;
            while k < occupied.len() && occupied[k] < end {
                k += 1;
            }
        }
        self.band_occupied.push(k as u32);
        self.cell_start = start;
        self.occupied = occupied;
    }

    #[inline]
    fn cell_range(&self, c: usize) -> Range<usize> {
        self.cell_start[c] as usize..self.cell_start[c + 1] as usize
    }

    fn band_row_range(&self, b: usize) -> Range<usize> {
        b * self.band_rows..((b + 1) * self.band_rows).min(self.rows)
    }

    /// The ball in each slot (see the module comment).
    pub fn slots(&self) -> &[u32] {
        &self.slots
    }

    /// The slot of each ball (the inverse of [`BroadPhase::slots`]).
    pub fn ball_slots(&self) -> &[u32] {
        &self.ball_slot
    }

    /// Number of bands (at least 1 after an update).
    pub fn band_count(&self) -> usize {
        self.bands
    }

    /// The slots of the balls in band b: a contiguous run.
    pub fn band_slots(&self, b: usize) -> Range<usize> {
        let rows = self.band_row_range(b);
        self.cell_start[rows.start * self.cols] as usize..self.cell_start[rows.end * self.cols] as usize
    }

    /// The slots of the balls seam b can touch (top row of band b, bottom row of band b + 1):
    /// a contiguous run. Seams are numbered 0..band_count() − 1.
    pub fn seam_slots(&self, b: usize) -> Range<usize> {
        let top = self.band_row_range(b).end;
        let first = (top - 1) * self.cols;
        let end = ((top + 1).min(self.rows)) * self.cols;
        self.cell_start[first] as usize..self.cell_start[end] as usize
    }

    /// The slots of the big balls.
    pub fn big_slots(&self) -> Range<usize> {
        let grid = self.cell_start.last().copied().unwrap_or(0) as usize;
        grid..grid + self.big.len()
    }

    /// Calls `f(k, m)` with the slots of every touching pair inside band b, in a fixed order.
    pub fn for_each_band_pair<F: FnMut(usize, usize)>(&self, b: usize, mut f: F) {
        let rows = self.band_row_range(b);
        let (cols, shape) = (self.cols, &self.slot_shape);
        let cells = &self.occupied[self.band_occupied[b] as usize..self.band_occupied[b + 1] as usize];
        for &c in cells {
            let c = c as usize;
            let (cx, cy) = (c % cols, c / cols);
            // Half stencil: this cell with itself and its east neighbour (one run of slots, as
            // cells are in row-major order), then with the three cells above it (one run too),
            // so each neighbouring pair of cells is visited from one side only. The row above
            // belongs to this band unless cy is its top row (those pairs are the seam's).
            let here = self.cell_range(c);
            let east_end = self.cell_start[(c + 2).min((cy + 1) * cols)] as usize;
            for k in here.clone() {
                for m in (k + 1)..east_end {
                    if touching(&shape[k], &shape[m]) {
                        f(k, m);
                    }
                }
            }
            if cy + 1 < rows.end {
                self.visit_row_above(here, c, cx, &mut f);
            }
        }
    }

    /// Calls `f(k, m)` with the slots of every touching pair on seam b (see the module comment).
    pub fn for_each_seam_pair<F: FnMut(usize, usize)>(&self, b: usize, mut f: F) {
        let top = self.band_row_range(b).end;
        if top >= self.rows {
            return;
        }
        let cols = self.cols;
        let row = (top - 1) * cols..top * cols;
        let cells = &self.occupied[self.band_occupied[b] as usize..self.band_occupied[b + 1] as usize];
        let first = cells.partition_point(|&c| (c as usize) < row.start);
        for &c in &cells[first..] {
            let c = c as usize;
            self.visit_row_above(self.cell_range(c), c, c % cols, &mut f);
        }
    }

    /// Pairs of the slots `here` (cell c, column cx) with the balls of the three cells above c
    /// (NW, N, NE: one run of slots).
    #[inline(always)]
    fn visit_row_above<F: FnMut(usize, usize)>(&self, here: Range<usize>, c: usize, cx: usize, f: &mut F) {
        let cols = self.cols;
        let above = c + cols;
        let first = self.cell_start[above - usize::from(cx > 0)] as usize;
        let end = self.cell_start[above + 1 + usize::from(cx + 1 < cols)] as usize;
        let shape = &self.slot_shape;
        for k in here {
            for m in first..end {
                if touching(&shape[k], &shape[m]) {
                    f(k, m);
                }
            }
        }
    }

    /// Calls `f(k, m)` with the slots of every touching pair that has a big ball: big against big
    /// directly, big against the small balls in the cells its bounding box (grown by one cell)
    /// covers. `k` is the big ball's slot.
    pub fn for_each_big_pair<F: FnMut(usize, usize)>(&self, mut f: F) {
        let big = self.big_slots();
        for k in big.clone() {
            let sa = self.slot_shape[k];
            self.visit_run(k, (k + 1)..big.end, &mut f);
            self.for_each_run_around(&sa, |run| self.visit_run(k, run, &mut f));
        }
    }

    /// Calls `f` with the slots of each grid row's cells that the box of `shape`, grown by one
    /// cell, covers: every small ball whose shape may touch `shape` is in one of these runs.
    fn for_each_run_around(&self, shape: &[f64; 3], mut f: impl FnMut(Range<usize>)) {
        let reach = shape[2] + self.cell;
        let lo = self.cell_of_point(shape[0] - reach, shape[1] - reach);
        let hi = self.cell_of_point(shape[0] + reach, shape[1] + reach);
        let (x0, y0, x1, y1) = (lo % self.cols, lo / self.cols, hi % self.cols, hi / self.cols);
        for cy in y0..=y1 {
            let row = cy * self.cols;
            f(self.cell_start[row + x0] as usize..self.cell_start[row + x1 + 1] as usize);
        }
    }

    /// Calls `f(m)` with the slot of every ball whose shape at the last [`BroadPhase::update`]
    /// touches the circle of `centre` and `radius` (a shape as the grid keeps them: a radius
    /// grown by the margin and half the skin): the small balls of the cells the circle's box
    /// (grown by one cell) covers, in slot order, then the big balls.
    pub fn for_each_near<F: FnMut(usize)>(&self, centre: glam::DVec2, radius: f64, mut f: F) {
        if self.slot_shape.is_empty() || self.cols == 0 || self.rows == 0 {
            return;
        }
        let sa = [centre.x, centre.y, radius];
        self.for_each_run_around(&sa, |run| {
            for m in run {
                if touching(&sa, &self.slot_shape[m]) {
                    f(m);
                }
            }
        });
        for m in self.big_slots() {
            if touching(&sa, &self.slot_shape[m]) {
                f(m);
            }
        }
    }

    /// Calls `add(a, b)` (slots, `a < b`) once for each pair of a ball of `beyond` with a ball
    /// that may touch it now, unless `known` holds the pair (as slots, either order) or `accept`
    /// turns the other ball's slot down: the balls whose shape at the last update touches the
    /// ball's circle ([`BroadPhase::for_each_near`]), and the other balls of `beyond` whose
    /// circles touch it. Each entry of `beyond` is a slot and the circle its ball may be in now
    /// (centre, radius), sorted by slot; `known` is looked at only when `beyond` is not empty.
    /// Returns how many pairs were added.
    ///
    /// For a ball that moved beyond the grid's view within a step or a span (struck, or pushed
    /// by the position passes): the pairs the grid reported were those of the balls where it
    /// saw them. Both engines' contact solvers look such balls up here.
    pub fn for_each_pair_beyond(
        &self,
        beyond: &[(usize, glam::DVec2, f64)],
        known: impl IntoIterator<Item = (u32, u32)>,
        accept: impl Fn(usize) -> bool,
        mut add: impl FnMut(u32, u32),
    ) -> u64 {
        if beyond.is_empty() {
            return 0;
        }
        let is_beyond = |k: u32| beyond.binary_search_by_key(&(k as usize), |b| b.0).is_ok();
        let mut seen: rustc_hash::FxHashSet<(u32, u32)> = known
            .into_iter()
            .filter(|&(a, b)| is_beyond(a) || is_beyond(b))
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        let mut added = 0;
        for (n, &(k, centre, radius)) in beyond.iter().enumerate() {
            let mut pair = |m: usize| {
                let (a, b) = (k.min(m) as u32, k.max(m) as u32);
                if m != k && accept(m) && seen.insert((a, b)) {
                    add(a, b);
                    added += 1;
                }
            };
            // The grid knows the others where they were; one that is itself beyond is met
            // where it may be now.
            self.for_each_near(centre, radius, &mut pair);
            for &(m, other, reach) in &beyond[n + 1..] {
                if centre.distance_squared(other) < (radius + reach) * (radius + reach) {
                    pair(m);
                }
            }
        }
        added
    }

    /// Where slot `k`'s ball was at the last [`BroadPhase::update`], and its shape's radius (its
    /// own, grown by the margin and half the skin).
    pub fn slot_shape(&self, k: usize) -> (glam::DVec2, f64) {
        let s = self.slot_shape[k];
        (glam::DVec2::new(s[0], s[1]), s[2])
    }

    /// Pairs of slot k with the slots of `run` that touch it.
    #[inline(always)]
    fn visit_run<F: FnMut(usize, usize)>(&self, k: usize, run: Range<usize>, f: &mut F) {
        let sa = self.slot_shape[k];
        for (m, sb) in self.slot_shape[run.clone()].iter().enumerate() {
            if touching(&sa, sb) {
                f(k, run.start + m);
            }
        }
    }

    /// Calls `f(i, j)` once for every pair of balls (indices, not slots) that overlap (centres
    /// closer than the sum of the radii) at the positions given to the last
    /// [`BroadPhase::update`]. The order is deterministic: the bands in order, then the seams,
    /// then the big balls.
    pub fn for_each_touching_pair<F: FnMut(usize, usize)>(&self, mut f: F) {
        let slots = &self.slots;
        let mut g = |k: usize, m: usize| f(slots[k] as usize, slots[m] as usize);
        for b in 0..self.bands {
            self.for_each_band_pair(b, &mut g);
        }
        for b in 0..self.bands.saturating_sub(1) {
            self.for_each_seam_pair(b, &mut g);
        }
        self.for_each_big_pair(&mut g);
    }
}

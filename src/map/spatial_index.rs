//! A uniform-grid index over the segments of many polylines, so nearest-lane
//! and road-edge queries touch only the segments near the query point.
//!
//! Queries are total: any point (huge, infinite or NaN) and any radius give
//! an answer after at most one pass over the occupied cells. Cell ranges are
//! computed in `f64` and compared against the occupied cells when they are
//! wider than the index, so no query walks an astronomically wide range of
//! empty cells (a position of 1e20 m once made this a busy loop). Building
//! is total too: segments with a non-finite end are left out, and finite
//! segments too long to walk cell by cell are offered to every query.

use std::collections::{BTreeMap, HashMap};

use crate::geometry::{Point2, Polyline};

const CELL_M: f64 = 10.0;

/// Most half-cell pieces one segment is walked in: segments up to ~5,200 km
/// are indexed cell by cell; longer ones (only absurd map data has them)
/// are kept aside and offered to every query, so building stays linear.
const MAX_PIECES: f64 = (1u32 << 20) as f64;

/// Most cells [`SegmentIndex::for_each_candidate_nearest_first`] orders
/// (a ring of up to 32 m radius spans at most 8 × 8, the second ring of
/// the road-edge search, which a point more than 8 m from every kerb of a
/// wide road or junction needs); wider queries visit their cells
/// unordered and unpruned.
const MAX_ORDERED_CELLS: usize = 64;

/// Slack of the cell and run pruning, m: far above the rounding of the
/// distances it compares, far below anything that matters.
const PRUNE_SLACK_M: f64 = 0.01;

/// Most segments in one run of a cell (see [`Run`]): recorded maps sample
/// a lane every metre or less, so a 10 m cell holds runs of 10–20
/// consecutive segments of each lane; runs of 8 let a query skip most of
/// a lane that only brushes its search circle.
const MAX_RUN_SEGMENTS: usize = 8;

/// A segment's two ends.
type SegmentEnds = [Point2; 2];

/// A segment reference `(polyline, segment)` with its two ends, as a cell
/// is built from them.
type EndedSegment = ((u32, u32), SegmentEnds);

/// The bounding box of a segment's ends.
fn segment_box([a, b]: &SegmentEnds) -> (Point2, Point2) {
    (Point2::new(a.x.min(b.x), a.y.min(b.y)), Point2::new(a.x.max(b.x), a.y.max(b.y)))
}

/// The distance from `p` to the axis-aligned box `lo`–`hi`: no point in it
/// is nearer.
fn box_distance_m(lo: &Point2, hi: &Point2, p: &Point2) -> f64 {
    let dx = (lo.x - p.x).max(p.x - hi.x).max(0.0);
    let dy = (lo.y - p.y).max(p.y - hi.y).max(0.0);
    (dx * dx + dy * dy).sqrt()
}

/// Consecutive segments of one polyline within a cell (at most
/// [`MAX_RUN_SEGMENTS`]), with the bounding box of those whole segments: a
/// query skips a run whose box lies beyond its reach.
#[derive(Debug, Clone, Copy)]
struct Run {
    /// End of the run in the cell's `refs` (exclusive; it starts where the
    /// previous run ends).
    end: u32,
    lo: Point2,
    hi: Point2,
}

/// The segments of one cell, sorted by polyline and segment and cut into
/// runs, and the bounding box of those whole segments (which may reach
/// beyond the cell).
#[derive(Debug, Clone)]
struct Cell {
    refs: Vec<(u32, u32)>,
    /// Each reference's segment ends, beside it: a query reads them from
    /// here, in order, rather than from each polyline's points scattered
    /// over the heap (which, with the planner's own data about, cost
    /// several times the arithmetic).
    ends: Vec<SegmentEnds>,
    runs: Vec<Run>,
    lo: Point2,
    hi: Point2,
}

impl Cell {
    /// A cell of these segments.
    fn new(mut segments: Vec<EndedSegment>) -> Self {
        segments.sort_unstable_by_key(|s| s.0);
        let mut runs: Vec<Run> = Vec::new();
        let mut run_start = 0;
        for (i, &((line, seg), ends)) in segments.iter().enumerate() {
            let (lo, hi) = segment_box(&ends);
            let continues =
                i > run_start && i - run_start < MAX_RUN_SEGMENTS && segments[i - 1].0 == (line, seg.wrapping_sub(1));
            match runs.last_mut() {
                Some(run) if continues => {
                    run.end = i as u32 + 1;
                    run.lo = Point2::new(run.lo.x.min(lo.x), run.lo.y.min(lo.y));
                    run.hi = Point2::new(run.hi.x.max(hi.x), run.hi.y.max(hi.y));
                }
                _ => {
                    run_start = i;
                    runs.push(Run { end: i as u32 + 1, lo, hi });
                }
            }
        }
        let lo =
            runs.iter().fold(Point2::new(f64::MAX, f64::MAX), |b, r| Point2::new(b.x.min(r.lo.x), b.y.min(r.lo.y)));
        let hi =
            runs.iter().fold(Point2::new(f64::MIN, f64::MIN), |b, r| Point2::new(b.x.max(r.hi.x), b.y.max(r.hi.y)));
        let (refs, ends) = segments.into_iter().unzip();
        Self { refs, ends, runs, lo, hi }
    }

    /// Distance from `p` to the bounding box of the cell's segments: none
    /// of them is nearer.
    fn distance_from(&self, p: &Point2) -> f64 {
        box_distance_m(&self.lo, &self.hi, p)
    }

    /// The cell's runs, each with its segment references and their ends.
    fn runs(&self) -> impl Iterator<Item = (&Run, &[(u32, u32)], &[SegmentEnds])> {
        let starts = std::iter::once(0).chain(self.runs.iter().map(|r| r.end as usize));
        self.runs.iter().zip(starts).map(|(run, start)| {
            let range = start..run.end as usize;
            (run, &self.refs[range.clone()], &self.ends[range])
        })
    }
}

/// The occupied cells by cell coordinates, hashed with foldhash's fixed
/// state.
type CellMap = HashMap<(i64, i64), Cell, foldhash::fast::FixedState>;

/// Grid of segment references `(polyline, segment)` keyed by cell.
#[derive(Debug, Clone, Default)]
pub struct SegmentIndex {
    /// Hashed with foldhash's fixed state: cell lookups are the hot path of
    /// every query, where the default SipHash showed; a fixed state keeps
    /// the scan order of wide queries the same from run to run.
    cells: CellMap,
    /// Finite segments too long to walk cell by cell: candidates of every query.
    oversized: Vec<EndedSegment>,
    /// Bounding box of all indexed points, `None` when empty.
    bounds: Option<(Point2, Point2)>,
}

fn cell_of(x: f64, y: f64) -> (i64, i64) {
    ((x / CELL_M).floor() as i64, (y / CELL_M).floor() as i64)
}

impl SegmentIndex {
    /// Indexes every segment of every polyline (in the given order). A
    /// segment with a non-finite end is near nothing and is left out; the
    /// work is linear in the total segment length (in cells) for any input.
    pub fn build<'a>(polylines: impl IntoIterator<Item = &'a Polyline>) -> Self {
        let mut cells: HashMap<(i64, i64), Vec<EndedSegment>> = HashMap::new();
        let mut oversized = Vec::new();
        let (mut lo, mut hi) = (Point2::new(f64::MAX, f64::MAX), Point2::new(f64::MIN, f64::MIN));
        for (pi, line) in polylines.into_iter().enumerate() {
            let pts = line.points();
            for (si, w) in pts.windows(2).enumerate() {
                let (a, b) = (w[0], w[1]);
                if !(a.x.is_finite() && a.y.is_finite() && b.x.is_finite() && b.y.is_finite()) {
                    continue;
                }
                for p in [a, b] {
                    lo = Point2::new(lo.x.min(p.x), lo.y.min(p.y));
                    hi = Point2::new(hi.x.max(p.x), hi.y.max(p.y));
                }
                // Walk the segment in pieces of at most half a cell and take each
                // piece's cells: a long diagonal segment then touches O(length)
                // cells, not the O(length²) of its bounding box. (The length of
                // two finite points can overflow to infinity: oversized too.)
                let pieces = ((b - a).norm() / (0.5 * CELL_M)).ceil().max(1.0);
                if pieces > MAX_PIECES {
                    oversized.push(((pi as u32, si as u32), [a, b]));
                    continue;
                }
                let pieces = pieces as usize;
                let mut touched: Vec<(i64, i64)> = Vec::new();
                for k in 0..pieces {
                    let (p, q) =
                        (a + (b - a) * (k as f64 / pieces as f64), a + (b - a) * ((k + 1) as f64 / pieces as f64));
                    // A piece spans at most 2×2 cells; cell numbers saturate
                    // far out, which only merges cells there.
                    let (c0, c1) = (cell_of(p.x.min(q.x), p.y.min(q.y)), cell_of(p.x.max(q.x), p.y.max(q.y)));
                    for cx in c0.0..=c1.0 {
                        for cy in c0.1..=c1.1 {
                            touched.push((cx, cy));
                        }
                    }
                }
                touched.sort_unstable();
                touched.dedup();
                for cell in touched {
                    cells.entry(cell).or_default().push(((pi as u32, si as u32), [a, b]));
                }
            }
        }
        let bounds = (lo.x <= hi.x).then_some((lo, hi));
        let cells: CellMap = cells.into_iter().map(|(key, segments)| (key, Cell::new(segments))).collect();
        Self { cells, oversized, bounds }
    }

    /// Distance from `p` to the farthest corner of the indexed extent: a
    /// ring search of that radius has seen every segment. Infinite for a
    /// non-finite `p`, so a ring search never stops on a NaN comparison.
    pub fn max_distance_from(&self, p: &Point2) -> f64 {
        if !(p.x.is_finite() && p.y.is_finite()) {
            return f64::INFINITY;
        }
        self.bounds.map_or(0.0, |(lo, hi)| {
            (p.x - lo.x).abs().max((p.x - hi.x).abs()).hypot((p.y - lo.y).abs().max((p.y - hi.y).abs()))
        })
    }

    /// Number of occupied cells (for tests and memory checks).
    pub fn cell_count(&self) -> usize {
        self.cells.len()
    }

    /// Segments in cells within `radius_m` of `p`, grouped by polyline and
    /// sorted, so callers iterate deterministically. Segments may lie
    /// farther than `radius_m`; callers check the distance. A non-finite `p`
    /// or a NaN radius has no candidates; an infinite radius has all.
    pub fn candidates(&self, p: &Point2, radius_m: f64) -> BTreeMap<usize, Vec<usize>> {
        let mut pairs = Vec::new();
        self.candidate_pairs_into(p, radius_m, &mut pairs);
        let mut out: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for (pi, si) in pairs {
            out.entry(pi as usize).or_default().push(si as usize);
        }
        out
    }

    /// The candidates of [`Self::candidates`] as `(polyline, segment)`
    /// pairs, sorted and without repeats, written into `out` (cleared
    /// first): for hot callers, with no map and no vector per polyline.
    pub fn candidate_pairs_into(&self, p: &Point2, radius_m: f64, out: &mut Vec<(u32, u32)>) {
        out.clear();
        self.for_each_candidate(p, radius_m, |pair| out.push(pair));
        out.sort_unstable();
        out.dedup();
    }

    /// As [`Self::for_each_candidate`], for searches of the segment nearest
    /// to `p` within `radius_m`: `visit` returns the distance of its best
    /// segment so far (`radius_m` or more while it has none), and the cells
    /// within reach are visited nearest first, skipping every cell and every
    /// run of segments in a cell that lie wholly farther than that or than
    /// `radius_m` (with a centimetre to spare), so such a search finds what
    /// it would find visiting them all, if that lies within `radius_m`.
    /// Each segment comes with its two ends; segments may still be visited
    /// more than once.
    pub fn for_each_candidate_nearest_first(
        &self,
        p: &Point2,
        radius_m: f64,
        mut visit: impl FnMut((u32, u32), &SegmentEnds) -> f64,
    ) {
        if !(p.x.is_finite() && p.y.is_finite()) || radius_m.is_nan() {
            return;
        }
        let r = radius_m.max(0.0);
        let (lo_x, hi_x) = (((p.x - r) / CELL_M).floor(), ((p.x + r) / CELL_M).floor());
        let (lo_y, hi_y) = (((p.y - r) / CELL_M).floor(), ((p.y + r) / CELL_M).floor());
        let span = (hi_x - lo_x + 1.0) * (hi_y - lo_y + 1.0);
        // (NaN or infinite spans too.)
        if span.is_nan() || span > MAX_ORDERED_CELLS as f64 {
            self.oversized.iter().for_each(|(pair, ends)| {
                visit(*pair, ends);
            });
            self.for_each_cell(p, radius_m, |cell| {
                cell.refs.iter().zip(&cell.ends).for_each(|(&pair, ends)| {
                    visit(pair, ends);
                })
            });
            return;
        }
        let mut near: [(f64, Option<&Cell>); MAX_ORDERED_CELLS] = [(0.0, None); MAX_ORDERED_CELLS];
        let mut n = 0;
        for cx in lo_x as i64..=hi_x as i64 {
            for cy in lo_y as i64..=hi_y as i64 {
                if let Some(cell) = self.cells.get(&(cx, cy)) {
                    near[n] = (cell.distance_from(p), Some(cell));
                    n += 1;
                }
            }
        }
        let near = &mut near[..n];
        near.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        let mut best_m = r;
        for (pair, ends) in &self.oversized {
            best_m = visit(*pair, ends).min(r);
        }
        for (distance_m, cell) in near.iter() {
            if *distance_m > best_m + PRUNE_SLACK_M {
                break;
            }
            for (run, pairs, ends) in cell.iter().flat_map(|c| c.runs()) {
                if box_distance_m(&run.lo, &run.hi, p) > best_m + PRUNE_SLACK_M {
                    continue;
                }
                for (&pair, ends) in pairs.iter().zip(ends) {
                    best_m = visit(pair, ends).min(r);
                }
            }
        }
    }

    /// As [`Self::for_each_candidate`], leaving out runs of segments that
    /// all lie farther than `radius_m` from `p` (with a centimetre to
    /// spare): for callers that ignore segments beyond `radius_m` anyway.
    /// Every segment within `radius_m` is still visited, with its two ends
    /// (as the polyline holds them).
    pub fn for_each_candidate_within(
        &self,
        p: &Point2,
        radius_m: f64,
        mut visit: impl FnMut((u32, u32), &SegmentEnds),
    ) {
        self.for_each_run_within(p, radius_m, |_, pairs, ends| {
            pairs.iter().zip(ends).for_each(|(&pair, ends)| visit(pair, ends))
        });
    }

    /// [`Self::for_each_candidate_within`] run by run: `visit` gets each
    /// run's distance from `p` (no segment of it is nearer), its segment
    /// references (consecutive segments of one polyline) and their ends.
    /// The oversized segments come as runs of one at distance zero.
    pub fn for_each_run_within(
        &self,
        p: &Point2,
        radius_m: f64,
        mut visit: impl FnMut(f64, &[(u32, u32)], &[SegmentEnds]),
    ) {
        if radius_m.is_nan() {
            return;
        }
        let reach_m = radius_m.max(0.0) + PRUNE_SLACK_M;
        for (pair, ends) in self.oversized_for(p, radius_m) {
            visit(0.0, std::slice::from_ref(pair), std::slice::from_ref(ends));
        }
        self.for_each_cell(p, radius_m, |cell| {
            for (run, pairs, ends) in cell.runs() {
                let distance_m = box_distance_m(&run.lo, &run.hi, p);
                if distance_m <= reach_m {
                    visit(distance_m, pairs, ends);
                }
            }
        });
    }

    /// As [`Self::candidate_pairs_into`], for [`Self::for_each_candidate_within`].
    pub fn candidate_pairs_within_into(&self, p: &Point2, radius_m: f64, out: &mut Vec<(u32, u32)>) {
        out.clear();
        self.for_each_candidate_within(p, radius_m, |pair, _| out.push(pair));
        out.sort_unstable();
        out.dedup();
    }

    /// Calls `visit` with every candidate of [`Self::candidates`] as a
    /// `(polyline, segment)` pair, in no particular order and some more
    /// than once (a segment is in every cell it crosses): for callers whose
    /// answer depends on neither, with no sorting at all.
    pub fn for_each_candidate(&self, p: &Point2, radius_m: f64, mut visit: impl FnMut((u32, u32))) {
        self.oversized_for(p, radius_m).iter().for_each(|(pair, _)| visit(*pair));
        self.for_each_cell(p, radius_m, |cell| cell.refs.iter().for_each(|&pair| visit(pair)));
    }

    /// The oversized segments, offered to every query (none for a
    /// non-finite `p` or a NaN radius, which have no candidates).
    fn oversized_for(&self, p: &Point2, radius_m: f64) -> &[EndedSegment] {
        if !(p.x.is_finite() && p.y.is_finite()) || radius_m.is_nan() { &[] } else { &self.oversized }
    }

    /// Calls `in_cell` on every occupied cell within `radius_m` of `p`
    /// (none for a non-finite `p` or a NaN radius).
    fn for_each_cell(&self, p: &Point2, radius_m: f64, mut in_cell: impl FnMut(&Cell)) {
        if !(p.x.is_finite() && p.y.is_finite()) || radius_m.is_nan() {
            return;
        }
        let r = radius_m.max(0.0);
        // Cell bounds as f64: exact for any cell the index can hold, and free
        // of the i64 overflow that `(x / CELL_M) as i64` saturation plus
        // `hi - lo + 1` arithmetic ran into for huge coordinates.
        let (lo_x, hi_x) = (((p.x - r) / CELL_M).floor(), ((p.x + r) / CELL_M).floor());
        let (lo_y, hi_y) = (((p.y - r) / CELL_M).floor(), ((p.y + r) / CELL_M).floor());
        let span = (hi_x - lo_x + 1.0) * (hi_y - lo_y + 1.0);
        if span.is_finite() && span <= self.cells.len() as f64 {
            // Few enough cells to look each up; all bounds are small integers here.
            for cx in lo_x as i64..=hi_x as i64 {
                for cy in lo_y as i64..=hi_y as i64 {
                    if let Some(cell) = self.cells.get(&(cx, cy)) {
                        in_cell(cell);
                    }
                }
            }
        } else {
            // A query wider than the whole index scans every occupied cell once.
            for (key, cell) in &self.cells {
                let (cx, cy) = (key.0 as f64, key.1 as f64);
                if (lo_x..=hi_x).contains(&cx) && (lo_y..=hi_y).contains(&cy) {
                    in_cell(cell);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_diagonal_segment_touches_cells_along_it_only() {
        let diagonal = Polyline::new(vec![Point2::new(0.0, 0.0), Point2::new(10_000.0, 10_000.0)]);
        let index = SegmentIndex::build([&diagonal]);
        // ~1414 cells of 10 m along a 14.1 km diagonal (its bounding box has a million).
        assert!(index.cell_count() < 5_000, "{}", index.cell_count());
        let hits = index.candidates(&Point2::new(5_000.0, 5_000.0), 1.0);
        assert_eq!(hits.get(&0), Some(&vec![0]));
    }

    #[test]
    fn nearest_first_visits_finds_the_same_nearest_segment_with_fewer_visits() {
        // Short random segments over 200 m × 200 m; for points all over it,
        // the nearest segment within the radius (by distance, then pair) is
        // the same with cells pruned as with all cells visited.
        let mut state = 11u64;
        let mut next = move || {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        let lines: Vec<Polyline> = (0..1500)
            .map(|_| {
                let a = Point2::new(next() * 200.0, next() * 200.0);
                let b = a + crate::geometry::Vector2::new(next() * 12.0 - 6.0, next() * 12.0 - 6.0);
                Polyline::new(vec![a, b, b + crate::geometry::Vector2::new(next() * 4.0, 1.0)])
            })
            .collect();
        let index = SegmentIndex::build(&lines);
        let distance =
            |p: &Point2, (pi, si): (u32, u32)| lines[pi as usize].segment_distance_squared(p, si as usize).0.sqrt();
        let (mut all_visits, mut pruned_visits) = (0, 0);
        for k in 0..2000 {
            let p = Point2::new(next() * 220.0 - 10.0, next() * 220.0 - 10.0);
            for r in [3.0, 8.0, 30.0, 50.0] {
                let mut all: Option<(f64, (u32, u32))> = None;
                index.for_each_candidate(&p, r, |pair| {
                    all_visits += usize::from(r < 40.0);
                    let key = (distance(&p, pair), pair);
                    if all.is_none_or(|b| key < b) {
                        all = Some(key);
                    }
                });
                let mut pruned: Option<(f64, (u32, u32))> = None;
                index.for_each_candidate_nearest_first(&p, r, |pair, _| {
                    pruned_visits += usize::from(r < 40.0);
                    let key = (distance(&p, pair), pair);
                    if pruned.is_none_or(|b| key < b) {
                        pruned = Some(key);
                    }
                    pruned.map_or(f64::INFINITY, |b| b.0)
                });
                let within = |best: Option<(f64, (u32, u32))>| best.filter(|b| b.0 <= r);
                assert_eq!(within(pruned), within(all), "point {k} {p:?} radius {r}");
            }
        }
        // Rings of up to 32 m are ordered and pruned.
        assert!(pruned_visits * 4 < all_visits * 3, "{pruned_visits} of {all_visits}");
    }

    #[test]
    fn a_search_within_a_radius_visits_every_segment_within_it_and_few_beyond() {
        // Finely sampled curves (as recorded lanes are), many to a cell: the
        // runs beyond the radius are skipped, none within it.
        let lines: Vec<Polyline> = (0..40)
            .map(|i| {
                let (cx, cy, r) = (i as f64 * 7.0 % 90.0, i as f64 * 13.0 % 70.0, 10.0 + i as f64);
                Polyline::new(
                    (0..=120)
                        .map(|k| k as f64 * 0.02)
                        .map(|a: f64| Point2::new(cx + r * a.cos(), cy + r * a.sin()))
                        .collect(),
                )
            })
            .collect();
        let index = SegmentIndex::build(&lines);
        let within = |p: &Point2, r: f64, (pi, si): (u32, u32)| {
            lines[pi as usize].segment_distance_squared(p, si as usize).0 <= r * r
        };
        let (mut all_visits, mut pruned_visits, mut found) = (0, 0, 0);
        for ix in 0..60 {
            for iy in 0..50 {
                let p = Point2::new(ix as f64 * 2.1 - 10.0, iy as f64 * 2.3 - 10.0);
                for r in [0.0, 2.5, 5.0, 12.0] {
                    let (mut all, mut pruned) = (Vec::new(), Vec::new());
                    index.for_each_candidate(&p, r, |pair| {
                        all_visits += 1;
                        all.extend(within(&p, r, pair).then_some(pair));
                    });
                    index.for_each_candidate_within(&p, r, |pair, ends| {
                        pruned_visits += 1;
                        let (line, seg) = (&lines[pair.0 as usize], pair.1 as usize);
                        assert_eq!(ends, &[line.points()[seg], line.points()[seg + 1]], "the segment's own ends");
                        pruned.extend(within(&p, r, pair).then_some(pair));
                    });
                    for v in [&mut all, &mut pruned] {
                        v.sort_unstable();
                        v.dedup();
                    }
                    assert_eq!(pruned, all, "{p:?} within {r} m");
                    found += all.len();
                    let mut pairs = Vec::new();
                    index.candidate_pairs_within_into(&p, r, &mut pairs);
                    assert!(all.iter().all(|pair| pairs.binary_search(pair).is_ok()));
                    assert!(pairs.windows(2).all(|w| w[0] < w[1]));
                }
            }
        }
        assert!(found > 10_000, "{found}");
        assert!(pruned_visits * 2 < all_visits, "{pruned_visits} of {all_visits}");
    }

    #[test]
    fn a_cells_runs_hold_consecutive_segments_of_one_polyline() {
        let line = Polyline::new((0..=40).map(|k| Point2::new(k as f64 * 0.2, 1.0)).collect());
        let other = Polyline::new(vec![Point2::new(1.0, 0.0), Point2::new(1.0, 9.0)]);
        let index = SegmentIndex::build([&line, &other]);
        let cell = &index.cells[&(0, 0)];
        let mut start = 0;
        for (run, pairs, _) in cell.runs() {
            assert!(!pairs.is_empty() && pairs.len() <= MAX_RUN_SEGMENTS);
            assert!(pairs.windows(2).all(|w| w[1] == (w[0].0, w[0].1 + 1)), "{pairs:?}");
            for &(pi, si) in pairs {
                let pts = [&line, &other][pi as usize].points();
                for q in [pts[si as usize], pts[si as usize + 1]] {
                    assert!(run.lo.x <= q.x && q.x <= run.hi.x && run.lo.y <= q.y && q.y <= run.hi.y);
                }
            }
            start += pairs.len();
        }
        assert_eq!(start, cell.refs.len());
        assert_eq!(cell.refs.len(), 41);
        assert_eq!(cell.runs.len(), 6);
    }

    fn two_segments() -> SegmentIndex {
        let a = Polyline::new(vec![Point2::new(0.0, 0.0), Point2::new(100.0, 0.0)]);
        let b = Polyline::new(vec![Point2::new(0.0, 50.0), Point2::new(100.0, 50.0)]);
        SegmentIndex::build([&a, &b])
    }

    #[test]
    fn huge_and_non_finite_queries_return_at_once() {
        // Each of these once walked (or overflowed into) an i64 range of
        // empty cells; now they are answered from the occupied cells.
        let index = two_segments();
        for (p, r) in [
            (Point2::new(1e20, 0.0), 1e20),
            (Point2::new(1e20, -1e20), 8.0),
            (Point2::new(-1e300, 1e300), 1e300),
            (Point2::new(0.0, 0.0), f64::INFINITY),
            (Point2::new(0.0, 0.0), f64::MAX),
            (Point2::new(9e18, 9e18), 1e19),
        ] {
            let hits = index.candidates(&p, r);
            assert!(hits.len() <= 2, "{p:?} {r}: {hits:?}");
        }
        // A huge radius around the map sees both polylines; infinity does too.
        assert_eq!(index.candidates(&Point2::new(1e20, 0.0), 2e20).len(), 2);
        assert_eq!(index.candidates(&Point2::new(0.0, 0.0), f64::INFINITY).len(), 2);
        // NaN anywhere: no candidates, and an infinite ring-search bound.
        assert!(index.candidates(&Point2::new(f64::NAN, 0.0), 10.0).is_empty());
        assert!(index.candidates(&Point2::new(0.0, 0.0), f64::NAN).is_empty());
        assert!(index.candidates(&Point2::new(f64::INFINITY, 0.0), 10.0).is_empty());
        assert_eq!(index.max_distance_from(&Point2::new(f64::NAN, 0.0)), f64::INFINITY);
    }

    #[test]
    fn absurd_map_segments_build_at_once_and_stay_findable() {
        // (0,0)→(1e20,0) once meant walking 1e19 cells; NaN and 1e300 ends too.
        let far = Polyline::new(vec![Point2::new(0.0, 0.0), Point2::new(1e20, 0.0)]);
        let nan = Polyline::new(vec![Point2::new(0.0, 0.0), Point2::new(f64::NAN, 5.0)]);
        let huge = Polyline::new(vec![Point2::new(-1e300, 1e300), Point2::new(1e300, -1e300)]);
        let near = Polyline::new(vec![Point2::new(0.0, 20.0), Point2::new(30.0, 20.0)]);
        let index = SegmentIndex::build([&far, &nan, &huge, &near]);
        // Only the ordinary segment is in cells (4 of them); the absurd ones
        // are offered to every query, the NaN one to none.
        assert_eq!(index.cell_count(), 4);
        let hits = index.candidates(&Point2::new(5.0, 20.0), 1.0);
        assert_eq!(hits.keys().copied().collect::<Vec<_>>(), vec![0, 2, 3]);
        // The bounds take in the absurd segments, so a ring search reaches them.
        assert!(index.max_distance_from(&Point2::new(0.0, 0.0)) > 1e300);
    }
}

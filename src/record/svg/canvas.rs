//! Metres to pixels: the view's bounds (cropped to the ego's and CBV's
//! paths around the ego's collision, plus margin, never the whole map), the
//! y-flipping transform, footprints in pixels, pixel rectangles for label
//! placement, and the number and text writers that keep the output
//! byte-identical (two decimals, no `-0.00`, no `NaN`; XML escaping).

use std::fmt::{self, Write as _};

use super::SvgOptions;
use super::picture::{Picture, Role, radius};
use crate::geometry::{OrientedBox, Point2, Pose2};
use crate::scenario::AgentBody;

/// Narrowest picture, pixels: the caption and the legend need the room.
pub(super) const MIN_WIDTH_PX: f64 = 760.0;
/// Height of the caption band, pixels.
pub(super) const CAPTION_PX: f64 = 54.0;
/// Smallest drawn footprint side, pixels, so pedestrians stay visible.
pub(super) const MIN_BOX_PX: f64 = 4.0;

/// A number with two decimals, never `-0.00`, never `NaN` (callers skip
/// non-finite values; this is the last guard).
pub(super) struct N(pub(super) f64);

impl fmt::Display for N {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = if self.0.is_finite() && self.0.abs() >= 0.005 { self.0 } else { 0.0 };
        write!(f, "{v:.2}")
    }
}

/// Escapes text for XML content and attribute values.
pub(super) use crate::record::markup::escape_attribute as esc;

/// An axis-aligned box in metres; empty until something is included.
#[derive(Debug, Clone, Copy)]
pub(super) struct Bounds {
    pub(super) lo: Point2,
    pub(super) hi: Point2,
}

impl Bounds {
    pub(super) fn empty() -> Self {
        Self { lo: Point2::new(f64::INFINITY, f64::INFINITY), hi: Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY) }
    }

    pub(super) fn is_empty(&self) -> bool {
        !(self.lo.x <= self.hi.x && self.lo.y <= self.hi.y)
    }

    pub(super) fn include(&mut self, p: &Point2, r: f64) {
        if p.x.is_finite() && p.y.is_finite() && r.is_finite() {
            self.lo = Point2::new(self.lo.x.min(p.x - r), self.lo.y.min(p.y - r));
            self.hi = Point2::new(self.hi.x.max(p.x + r), self.hi.y.max(p.y + r));
        }
    }

    pub(super) fn of_points<'p>(pts: impl IntoIterator<Item = &'p Point2>) -> Self {
        let mut b = Self::empty();
        for p in pts {
            b.include(p, 0.0);
        }
        b
    }

    pub(super) fn intersects(&self, other: &Bounds) -> bool {
        !self.is_empty()
            && !other.is_empty()
            && self.lo.x <= other.hi.x
            && other.lo.x <= self.hi.x
            && self.lo.y <= other.hi.y
            && other.lo.y <= self.hi.y
    }

    pub(super) fn width(&self) -> f64 {
        self.hi.x - self.lo.x
    }

    pub(super) fn height(&self) -> f64 {
        self.hi.y - self.lo.y
    }

    /// Grows the box symmetrically to at least `w` × `h`.
    pub(super) fn grow_to(&mut self, w: f64, h: f64) {
        let dx = (w - self.width()).max(0.0) * 0.5;
        let dy = (h - self.height()).max(0.0) * 0.5;
        self.lo = Point2::new(self.lo.x - dx, self.lo.y - dy);
        self.hi = Point2::new(self.hi.x + dx, self.hi.y + dy);
    }
}

/// Metres to pixels: y flipped, map band below the caption.
pub(super) struct View {
    pub(super) bounds: Bounds,
    pub(super) scale: f64,
    pub(super) top: f64,
    pub(super) width: f64,
    pub(super) height: f64,
}

impl View {
    pub(super) fn px(&self, p: &Point2) -> (f64, f64) {
        ((p.x - self.bounds.lo.x) * self.scale, self.top + (self.bounds.hi.y - p.y) * self.scale)
    }

    /// `points` attribute text for a polyline, dropping points closer than
    /// half a pixel to the last one kept (smaller files, same picture).
    pub(super) fn points(&self, pts: &[Point2]) -> String {
        let mut out = String::new();
        let mut last: Option<(f64, f64)> = None;
        for (i, p) in pts.iter().enumerate() {
            if !(p.x.is_finite() && p.y.is_finite()) {
                continue;
            }
            let q = self.px(p);
            let keep = match last {
                None => true,
                Some(l) => i + 1 == pts.len() || (q.0 - l.0).hypot(q.1 - l.1) >= 0.5,
            };
            if keep {
                if !out.is_empty() {
                    out.push(' ');
                }
                let _ = write!(out, "{},{}", N(q.0), N(q.1));
                last = Some(q);
            }
        }
        out
    }
}

/// Steps of ego and CBV path kept in view before and after the ego's
/// collision: on a long road the whole paths would shrink the crash to a dot.
pub(super) const COLLISION_WINDOW_BEFORE: usize = 20;
pub(super) const COLLISION_WINDOW_AFTER: usize = 10;

/// The view: ego and CBV paths (around the ego's collision, when one is
/// shown), extra trajectories and the ego's collision partners, plus margin,
/// at least `min_extent_m`, at most `max_aspect`.
pub(super) fn focus(pic: &Picture, opts: &SvgOptions) -> Bounds {
    let mut b = Bounds::empty();
    let n = pic.states.num_steps();
    let is_ego = |i: usize| pic.agents.get(i).is_some_and(|a| a.role == Role::Ego);
    let ego_collision =
        pic.collisions.iter().filter(|c| c.k <= pic.shown && (is_ego(c.a) || is_ego(c.b))).map(|c| c.k).min();
    let steps = match ego_collision {
        Some(k) => k.saturating_sub(COLLISION_WINDOW_BEFORE)..(k + COLLISION_WINDOW_AFTER + 1).min(n),
        None => 0..n,
    };
    for (i, a) in pic.agents.iter().enumerate() {
        if a.role == Role::Other {
            continue;
        }
        let r = radius(&a.body);
        for k in steps.clone() {
            if let Some(s) = pic.states.get(k, i) {
                b.include(&s.position, r);
            }
        }
    }
    for e in pic.extras {
        let r = e.body.as_ref().map_or(1.0, radius);
        for p in &e.poses {
            b.include(&p.pose.position, r);
        }
    }
    // The ego's collision partners, where they hit it and where they are shown.
    for c in pic.collisions.iter().filter(|c| c.k <= pic.shown && (is_ego(c.a) || is_ego(c.b))) {
        for i in [c.a, c.b] {
            let Some(a) = pic.agents.get(i) else { continue };
            for k in [c.k, pic.shown] {
                if let Some(s) = pic.states.get(k, i) {
                    b.include(&s.position, radius(&a.body));
                }
            }
        }
    }
    if b.is_empty() {
        // No ego or CBV to follow: everyone present at the displayed step.
        for (i, a) in pic.agents.iter().enumerate() {
            if let Some(s) = pic.states.get(pic.shown, i) {
                b.include(&s.position, radius(&a.body));
            }
        }
    }
    if b.is_empty() {
        for l in &pic.map.lanes {
            for p in l.centreline.points() {
                b.include(p, 0.0);
            }
        }
        for e in &pic.map.road_edges {
            for p in e.polyline.points() {
                b.include(p, 0.0);
            }
        }
    }
    if b.is_empty() {
        b.include(&Point2::origin(), 0.0);
    }
    let margin = if opts.margin_m.is_finite() { opts.margin_m.max(0.0) } else { 0.0 };
    b.grow_to(b.width() + 2.0 * margin, b.height() + 2.0 * margin);
    let min_extent = if opts.min_extent_m.is_finite() { opts.min_extent_m.max(1.0) } else { 1.0 };
    b.grow_to(min_extent, min_extent);
    let aspect = if opts.max_aspect.is_finite() { opts.max_aspect.max(1.0) } else { 2.0 };
    b.grow_to(b.height() / aspect, b.width() / aspect);
    b
}

/// A footprint in pixels.
pub(super) struct BoxPx {
    /// `points` text of the outline.
    pub(super) outline: String,
    /// `points` text of the heading arrowhead in the front third.
    pub(super) head: String,
    /// Pixel extent, for placing labels around it.
    pub(super) extent: Rect,
}

pub(super) fn points_text(view: &View, pts: &[Point2]) -> String {
    let mut out = String::new();
    for (j, c) in pts.iter().enumerate() {
        let q = view.px(c);
        if j > 0 {
            out.push(' ');
        }
        let _ = write!(out, "{},{}", N(q.0), N(q.1));
    }
    out
}

/// The footprint at `pose`, at least [`MIN_BOX_PX`] on each side so small
/// agents stay visible; `None` for a non-finite size.
pub(super) fn box_px(view: &View, pose: &Pose2, body: &AgentBody) -> Option<BoxPx> {
    let (l, w) = (body.length_m, body.width_m);
    if !(l.is_finite() && w.is_finite()) {
        return None;
    }
    let (l, w) = ((l * view.scale).max(MIN_BOX_PX) / view.scale, (w * view.scale).max(MIN_BOX_PX) / view.scale);
    let corners = OrientedBox::new(*pose, l, w).corners();
    let at = |x: f64, y: f64| pose.from_body(&crate::geometry::Vector2::new(x, y));
    let back = 0.5 * l - (0.22 * l).min(1.2);
    let head = [at(0.5 * l, 0.0), at(back, 0.25 * w), at(back, -0.25 * w)];
    let px: Vec<(f64, f64)> = corners.iter().map(|c| view.px(c)).collect();
    Some(BoxPx { outline: points_text(view, &corners), head: points_text(view, &head), extent: Rect::around(&px) })
}

/// A pixel rectangle: a footprint's or marker's extent, or a label's.
#[derive(Debug, Clone, Copy)]
pub(super) struct Rect {
    pub(super) x0: f64,
    pub(super) y0: f64,
    pub(super) x1: f64,
    pub(super) y1: f64,
}

impl Rect {
    pub(super) fn around(points: &[(f64, f64)]) -> Self {
        let mut r = Rect { x0: f64::INFINITY, y0: f64::INFINITY, x1: f64::NEG_INFINITY, y1: f64::NEG_INFINITY };
        for &(x, y) in points {
            r = Rect { x0: r.x0.min(x), y0: r.y0.min(y), x1: r.x1.max(x), y1: r.y1.max(y) };
        }
        r
    }

    pub(super) fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    pub(super) fn inside(&self, o: &Rect) -> bool {
        self.x0 >= o.x0 && self.x1 <= o.x1 && self.y0 >= o.y0 && self.y1 <= o.y1
    }
}

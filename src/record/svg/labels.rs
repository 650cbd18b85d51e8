//! Text labels next to footprints and collision markers ("ego", "CBV",
//! collision times, ids of agents that hit a role), placed greedily at the
//! first free spot around their anchor so none hides another or a footprint.

use std::fmt::Write as _;

use super::canvas::{N, Rect, View, esc};

/// A label to place next to `anchor`.
pub(super) struct LabelRequest {
    pub(super) anchor: Rect,
    pub(super) text: String,
    pub(super) colour: &'static str,
}

/// Places each label at the first spot around its anchor that stays in the
/// map band and overlaps no footprint, marker or earlier label (greedy, in
/// request order, so the result is deterministic); falls back to the
/// first spot.
pub(super) fn place_labels(s: &mut String, view: &View, requests: &[LabelRequest], mut taken: Vec<Rect>) {
    let band = Rect { x0: 0.0, y0: view.top, x1: view.width, y1: view.top + view.height };
    for r in requests {
        // Bold 13 px sans-serif: about 8.5 px per character.
        let (w, h) = (8.5 * r.text.chars().count() as f64 + 2.0, 13.0);
        let a = r.anchor;
        let (xc, yc) = (0.5 * (a.x0 + a.x1), 0.5 * (a.y0 + a.y1));
        let at = |x: f64, y: f64| Rect { x0: x, y0: y, x1: x + w, y1: y + h };
        let mut candidates = Vec::new();
        for g in [4.0, 16.0, 32.0] {
            candidates.extend([
                at(a.x1 + g, yc - 0.5 * h),
                at(a.x0 - g - w, yc - 0.5 * h),
                at(xc - 0.5 * w, a.y0 - g - h),
                at(xc - 0.5 * w, a.y1 + g),
                at(a.x1 + g, a.y0 - g - h),
                at(a.x1 + g, a.y1 + g),
                at(a.x0 - g - w, a.y0 - g - h),
                at(a.x0 - g - w, a.y1 + g),
            ]);
        }
        let chosen = candidates
            .iter()
            .find(|c| c.inside(&band) && !taken.iter().any(|t| t.overlaps(c)))
            .copied()
            .unwrap_or(candidates[0]);
        taken.push(chosen);
        let _ = writeln!(
            s,
            "<text class=\"label\" fill=\"{}\" x=\"{}\" y=\"{}\">{}</text>",
            r.colour,
            N(chosen.x0 + 1.0),
            N(chosen.y1 - 2.0),
            esc(&r.text)
        );
    }
}

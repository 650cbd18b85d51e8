//! Top-down SVG pictures of a scenario or a rollout, for a person reviewing
//! a failed planner test.
//!
//! What a picture shows, bottom to top: the map (drivable areas very light,
//! crosswalks hatched, lane centrelines light and dashed, road lines, road
//! edges dark), every agent's trail over the whole run (faint), the ego's
//! and the CBV's paths (solid up to the displayed step, dashed after it,
//! a dot every second), extra trajectories such as a feasibility witness,
//! every agent's footprint at the displayed step with a heading tick (ego
//! blue, CBV orange, agents that have collided outlined red), a marker at
//! each collision point, a scale bar, a caption (scenario, planner, the
//! displayed time, the ego's collision: when and with whom) and a legend.
//!
//! The view is cropped to the ego's and CBV's paths (and extra
//! trajectories) plus a margin, never to the whole map: recorded maps span
//! kilometres and would shrink the conflict to a few pixels.
//!
//! Coordinates are metres with y up in the scenario; the picture flips y
//! so north is up. Pixel coordinates are written with two decimals, and
//! everything is emitted in index order, so the same input gives a
//! byte-identical SVG. Non-finite states and map points are skipped.
//!
//! This module holds the entry points and the order of the layers;
//! `picture` gathers what a picture shows from a scenario or a rollout,
//! `canvas` maps metres to pixels, `map`, `agents`, `labels` and `legend`
//! draw the layers, `style` holds the stylesheet and colours, and `lfr`
//! draws the feasibility-region figure (a different picture).

mod agents;
mod canvas;
mod labels;
mod legend;
mod lfr;
mod map;
mod picture;
mod style;
#[cfg(test)]
mod tests;

pub(in crate::record) use agents::contact_point;
pub use lfr::render_lfr_svg;

use agents::{draw_agents, draw_collisions, draw_extras, draw_trails};
use canvas::{CAPTION_PX, MIN_WIDTH_PX, N, View, esc, focus};
use labels::place_labels;
use legend::{draw_legend, draw_scale_bar, layout_legend, legend_items};
use map::draw_map;
use picture::Picture;
use style::{COLLISION, STYLE};

use std::fmt::Write as _;

use super::NamedTrajectory;
use crate::scenario::Scenario;
use crate::sim::Rollout;

/// How a picture is drawn.
#[derive(Debug, Clone, PartialEq)]
pub struct SvgOptions {
    /// Scenario step whose footprints are drawn. `None`: for a rollout, the
    /// ego's collision step if it has one, else its last step; for a
    /// scenario, its current step. Clamped into the run.
    pub step: Option<usize>,
    /// Length of the longer side of the map area, pixels.
    pub size_px: u32,
    /// Margin around the ego's and CBV's paths, metres.
    pub margin_m: f64,
    /// Smallest side of the view, metres (a standing ego still gets context).
    pub min_extent_m: f64,
    /// Largest ratio of the view's long side to its short side; a longer
    /// crop is widened on its short side (more context, no distortion).
    pub max_aspect: f64,
    /// Draw every agent's trail, not only the ego's and the CBV's.
    pub all_trails: bool,
}

impl Default for SvgOptions {
    fn default() -> Self {
        Self { step: None, size_px: 1200, margin_m: 15.0, min_extent_m: 60.0, max_aspect: 2.0, all_trails: true }
    }
}

/// The picture of a scenario without a rollout.
pub(super) fn render_scenario(scenario: &Scenario, opts: &SvgOptions) -> String {
    draw(&Picture::of_scenario(scenario, opts), opts)
}

/// The picture of a rollout, with extra trajectories.
pub(super) fn render_rollout(
    scenario: &Scenario,
    rollout: &Rollout,
    extras: &[NamedTrajectory],
    opts: &SvgOptions,
) -> String {
    draw(&Picture::of_rollout(scenario, rollout, extras, opts), opts)
}

/// Lays the picture out (view, caption band, map band, legend band) and
/// draws its layers bottom to top.
fn draw(pic: &Picture, opts: &SvgOptions) -> String {
    let mut bounds = focus(pic, opts);
    let size = f64::from(opts.size_px.max(100));
    let mut scale = size / bounds.width().max(bounds.height());
    if !(scale.is_finite() && scale > 0.0) {
        scale = 1.0;
    }
    // Widen narrow views instead of squeezing the caption and legend.
    bounds.grow_to(MIN_WIDTH_PX / scale, 0.0);
    let width = (bounds.width() * scale).round();
    let map_h = (bounds.height() * scale).round();
    let view = View { bounds, scale, top: CAPTION_PX, width, height: map_h };
    let legend = legend_items(pic, &view.bounds);
    let legend_rows = layout_legend(&legend, width);
    let legend_h = 14.0 + 22.0 * legend_rows.iter().map(|r| r.1 + 1).max().unwrap_or(0) as f64;
    let height = CAPTION_PX + map_h + legend_h;

    let mut s = String::with_capacity(256 * 1024);
    let _ = write!(
        s,
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" \
         height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"DejaVu Sans, Helvetica, Arial, sans-serif\">\n\
         <title>{title}</title>\n<defs>\n<style>{STYLE}</style>\n\
         <clipPath id=\"map-clip\"><rect x=\"0\" y=\"{top}\" width=\"{w}\" height=\"{mh}\"/></clipPath>\n\
         <pattern id=\"hatch\" patternUnits=\"userSpaceOnUse\" width=\"6\" height=\"6\" \
         patternTransform=\"rotate(45)\"><rect width=\"6\" height=\"6\" fill=\"#f4f4f4\"/>\
         <line x1=\"0\" y1=\"0\" x2=\"0\" y2=\"6\" stroke=\"#bdbdbd\" stroke-width=\"2.5\"/></pattern>\n</defs>\n",
        w = N(width),
        h = N(height),
        title = esc(&pic.title),
        top = N(CAPTION_PX),
        mh = N(map_h),
    );
    let _ = writeln!(s, "<rect class=\"bg\" x=\"0\" y=\"0\" width=\"{}\" height=\"{}\"/>", N(width), N(height));
    let _ = writeln!(s, "<g clip-path=\"url(#map-clip)\">");
    draw_map(&mut s, pic.map, &view);
    draw_trails(&mut s, pic, &view, opts);
    draw_extras(&mut s, pic, &view);
    let (mut taken, mut labels) = draw_agents(&mut s, pic, &view);
    let (markers, collision_labels) = draw_collisions(&mut s, pic, &view);
    taken.extend(markers);
    // Role labels first, then collision times, then other agents' ids.
    let roles = labels.iter().take_while(|l| l.colour != COLLISION).count();
    let others = labels.split_off(roles);
    labels.extend(collision_labels);
    labels.extend(others);
    place_labels(&mut s, &view, &labels, taken);
    let _ = writeln!(s, "</g>");
    draw_scale_bar(&mut s, &view);
    // Caption band on top, legend band below the map: neither hides the scene.
    let _ = writeln!(
        s,
        "<rect class=\"band\" x=\"0.5\" y=\"0.5\" width=\"{}\" height=\"{}\"/>\n\
         <text class=\"caption\" x=\"10\" y=\"22\">{}</text>\n<text class=\"sub\" x=\"10\" y=\"43\">{}</text>",
        N(width - 1.0),
        N(CAPTION_PX - 1.0),
        esc(&pic.caption[0]),
        esc(&pic.caption[1])
    );
    draw_legend(&mut s, &legend, &legend_rows, CAPTION_PX + map_h, width, legend_h);
    s.push_str("</svg>\n");
    s
}

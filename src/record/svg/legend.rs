//! The picture's key: the scale bar on the map, and the legend band below it
//! with one entry per thing the picture shows (roles, agent kinds in view,
//! collisions, paths, extra trajectories, map elements), wrapped to the
//! picture's width.

use std::collections::BTreeSet;
use std::fmt::Write as _;

use super::canvas::{Bounds, N, View, esc};
use super::picture::{Picture, Role, kind_name};
use super::style::{EGO, extra_colour};
use crate::map::AreaKind;
use crate::scenario::AgentKind;

/// A bar of a round length (1, 2 or 5 × 10ⁿ m) about a sixth of the width.
pub(super) fn draw_scale_bar(s: &mut String, view: &View) {
    let target = view.width / view.scale / 6.0;
    if !(target.is_finite() && target > 0.0) {
        return;
    }
    let p = 10f64.powf((target * (1.0 + 1e-9)).log10().floor());
    let len_m = [5.0, 2.0, 1.0].into_iter().map(|m| m * p).find(|l| *l <= target).unwrap_or(p);
    let len_px = len_m * view.scale;
    let (x0, y) = (14.0, view.top + view.height - 16.0);
    let _ = writeln!(
        s,
        "<g><rect x=\"{}\" y=\"{}\" width=\"{}\" height=\"22\" fill=\"#ffffff\" fill-opacity=\"0.85\"/>\
         <path class=\"scale\" d=\"M{},{} V{} H{} V{}\"/><text class=\"legend\" x=\"{}\" y=\"{}\">{} m</text></g>",
        N(x0 - 6.0),
        N(y - 14.0),
        N(len_px + 52.0),
        N(x0),
        N(y - 6.0),
        N(y),
        N(x0 + len_px),
        N(y - 6.0),
        N(x0 + len_px + 6.0),
        N(y + 1.0),
        if len_m >= 1.0 { format!("{len_m:.0}") } else { format!("{len_m}") }
    );
}

/// What a legend entry's swatch looks like.
pub(super) enum Swatch {
    Box(&'static str),
    Line(&'static str, &'static str),
    Marker,
}

/// Legend entries for what the picture shows (agent kinds only where one
/// is in `view`).
pub(super) fn legend_items(pic: &Picture, view: &Bounds) -> Vec<(Swatch, String)> {
    let mut items = Vec::new();
    let id_of = |role: Role| pic.agents.iter().find(|a| a.role == role).map(|a| a.id);
    if let Some(id) = id_of(Role::Ego) {
        items.push((Swatch::Box("box ego"), format!("ego ({id})")));
    }
    if let Some(id) = id_of(Role::Cbv) {
        items.push((Swatch::Box("box cbv"), format!("CBV ({id})")));
    }
    let kinds: BTreeSet<AgentKind> = pic
        .agents
        .iter()
        .enumerate()
        .filter(|(i, a)| {
            a.role == Role::Other
                && pic.states.get(pic.shown, *i).is_some_and(|s| Bounds::of_points([&s.position]).intersects(view))
        })
        .map(|(_, a)| a.body.kind)
        .collect();
    for k in kinds {
        let class = match k {
            AgentKind::Vehicle => "box vehicle",
            AgentKind::Pedestrian => "box pedestrian",
            AgentKind::Cyclist => "box cyclist",
            AgentKind::Other => "box other",
        };
        items.push((Swatch::Box(class), kind_name(k).to_string()));
    }
    if pic.collisions.iter().any(|c| c.k <= pic.shown) {
        items.push((Swatch::Box("box vehicle collided"), "collided".into()));
        items.push((Swatch::Marker, "collision point".into()));
    }
    items.push((Swatch::Line("path", EGO), "path so far".into()));
    items.push((Swatch::Line("path after", EGO), "path after shown step".into()));
    for e in pic.extras {
        items.push((Swatch::Line("extra", extra_colour(e)), format!("{}: {}", e.role.label(), e.name)));
    }
    items.push((Swatch::Line("edge", ""), "road edge".into()));
    items.push((Swatch::Line("lane", ""), "lane centreline".into()));
    if !pic.map.road_lines.is_empty() {
        items.push((Swatch::Line("line", ""), "road line".into()));
    }
    if pic.map.areas.iter().any(|a| a.kind == AreaKind::Crosswalk) {
        items.push((Swatch::Box("crosswalk"), "crosswalk".into()));
    }
    items
}

/// Row and x of every legend entry, wrapped to the picture's width.
pub(super) fn layout_legend(items: &[(Swatch, String)], width: f64) -> Vec<(f64, usize)> {
    let mut out = Vec::with_capacity(items.len());
    let (mut x, mut row) = (10.0, 0usize);
    for (_, text) in items {
        // 7 px per character is a safe estimate for 12 px sans-serif.
        let w = 34.0 + 7.0 * text.chars().count() as f64 + 14.0;
        if x + w > width - 10.0 && x > 10.0 {
            x = 10.0;
            row += 1;
        }
        out.push((x, row));
        x += w;
    }
    out
}

pub(super) fn draw_legend(
    s: &mut String,
    items: &[(Swatch, String)],
    rows: &[(f64, usize)],
    top: f64,
    width: f64,
    h: f64,
) {
    let _ = writeln!(
        s,
        "<g class=\"legend-band\"><rect class=\"band\" x=\"0.5\" y=\"{}\" width=\"{}\" height=\"{}\"/>",
        N(top + 0.5),
        N(width - 1.0),
        N(h - 1.0)
    );
    for ((swatch, text), (x, row)) in items.iter().zip(rows) {
        let y = top + 18.0 + 22.0 * *row as f64;
        match swatch {
            Swatch::Box(class) => {
                let _ = write!(
                    s,
                    "<rect class=\"{class}\" x=\"{}\" y=\"{}\" width=\"24\" height=\"11\"/>",
                    N(*x),
                    N(y - 9.0)
                );
            }
            Swatch::Line(class, colour) => {
                let stroke = if colour.is_empty() { String::new() } else { format!(" stroke=\"{colour}\"") };
                let _ = write!(
                    s,
                    "<polyline class=\"{class}\"{stroke} points=\"{},{} {},{}\"/>",
                    N(*x),
                    N(y - 4.0),
                    N(x + 24.0),
                    N(y - 4.0)
                );
            }
            Swatch::Marker => {
                let _ = write!(s, "<circle class=\"marker\" cx=\"{}\" cy=\"{}\" r=\"6\"/>", N(x + 12.0), N(y - 4.0));
            }
        }
        let _ = writeln!(s, "<text class=\"legend\" x=\"{}\" y=\"{}\">{}</text>", N(x + 32.0), N(y), esc(text));
    }
    let _ = writeln!(s, "</g>");
}

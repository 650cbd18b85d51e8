//! The map layer, bottom of the picture: drivable areas, crosswalks, speed
//! bumps and driveways, lane centrelines, road lines by kind, road edges and
//! stop signs, each drawn only where it reaches the view.

use std::fmt::Write as _;

use super::canvas::{Bounds, N, View};
use crate::geometry::Point2;
use crate::map::{AreaKind, RoadLineKind, RoadMap};

pub(super) fn draw_map(s: &mut String, map: &RoadMap, view: &View) {
    // A little slack so lines leaving the view are still drawn to its edge.
    let mut visible = view.bounds;
    visible.grow_to(view.bounds.width() + 20.0, view.bounds.height() + 20.0);
    let poly = |s: &mut String, class: &str, pts: &[Point2]| {
        if pts.len() >= 3 && Bounds::of_points(pts).intersects(&visible) {
            let _ = writeln!(s, "<polygon class=\"{class}\" points=\"{}\"/>", view.points(pts));
        }
    };
    let line = |s: &mut String, class: &str, pts: &[Point2]| {
        if pts.len() >= 2 && Bounds::of_points(pts).intersects(&visible) {
            let _ = writeln!(s, "<polyline class=\"{class}\" points=\"{}\"/>", view.points(pts));
        }
    };
    for a in &map.drivable_areas {
        poly(s, "drivable", &a.vertices);
    }
    for a in &map.areas {
        let class = match a.kind {
            AreaKind::Crosswalk => "crosswalk",
            AreaKind::SpeedBump => "bump",
            AreaKind::Driveway => "driveway",
        };
        poly(s, class, &a.polygon.vertices);
    }
    for l in &map.lanes {
        line(s, "lane", l.centreline.points());
    }
    for l in &map.road_lines {
        use RoadLineKind as K;
        let class = match l.kind {
            K::BrokenSingleWhite => "line broken",
            K::SolidSingleWhite | K::SolidDoubleWhite | K::Unknown => "line",
            K::BrokenSingleYellow | K::BrokenDoubleYellow => "line yellow broken",
            K::SolidSingleYellow | K::SolidDoubleYellow | K::PassingDoubleYellow => "line yellow",
        };
        line(s, class, l.polyline.points());
    }
    for e in &map.road_edges {
        line(s, "edge", e.polyline.points());
    }
    for st in &map.stop_signs {
        let p = st.position;
        if p.x.is_finite() && p.y.is_finite() && Bounds::of_points([&p]).intersects(&visible) {
            let (x, y) = view.px(&p);
            let _ = writeln!(s, "<circle class=\"stop\" cx=\"{}\" cy=\"{}\" r=\"3.5\"/>", N(x), N(y));
        }
    }
}

//! The agent layers: faint trails of every agent, the ego's and CBV's paths
//! (solid up to the shown step, dashed after, a dot every second), extra
//! trajectories such as a feasibility witness with their ghost at the shown
//! time, every footprint at the shown step with its heading, and a marker
//! at each collision point (the centroid of the two footprints' overlap).

use std::collections::BTreeSet;
use std::fmt::Write as _;

use super::SvgOptions;
use super::canvas::{Bounds, N, Rect, View, box_px, esc};
use super::labels::LabelRequest;
use super::picture::{Collision, Picture, Role, collided, involves_role, kind_name, runs, time_text};
use super::style::{CBV, COLLISION, EGO, extra_colour, role_class, role_colour};
use crate::geometry::{OrientedBox, Point2};

/// The overlap of two footprints (Sutherland–Hodgman on convex quads),
/// its centroid being the collision point; `None` when they only touch.
pub(super) fn overlap_centroid(a: &OrientedBox, b: &OrientedBox) -> Option<Point2> {
    let mut poly: Vec<Point2> = a.corners().to_vec();
    let clip = b.corners();
    for e in 0..4 {
        let (p, q) = (clip[e], clip[(e + 1) % 4]);
        // Corners are counter-clockwise, so inside is to the left of p→q.
        let side = |x: &Point2| (q.x - p.x) * (x.y - p.y) - (q.y - p.y) * (x.x - p.x);
        let input = std::mem::take(&mut poly);
        for j in 0..input.len() {
            let (cur, prev) = (input[j], input[(j + input.len() - 1) % input.len()]);
            let (sc, sp) = (side(&cur), side(&prev));
            if sc >= 0.0 {
                if sp < 0.0 {
                    poly.push(prev + (cur - prev) * (sp / (sp - sc)));
                }
                poly.push(cur);
            } else if sp >= 0.0 {
                poly.push(prev + (cur - prev) * (sp / (sp - sc)));
            }
        }
        if poly.is_empty() {
            return None;
        }
    }
    let n = poly.len() as f64;
    let c = Point2::new(poly.iter().map(|p| p.x).sum::<f64>() / n, poly.iter().map(|p| p.y).sum::<f64>() / n);
    (c.x.is_finite() && c.y.is_finite()).then_some(c)
}

pub(super) fn collision_point(pic: &Picture, c: &Collision) -> Option<Point2> {
    let footprint = |i: usize| {
        let s = pic.states.get(c.k, i)?;
        let body = pic.agents.get(i)?.body;
        Some(OrientedBox::new(s.pose(), body.length_m, body.width_m))
    };
    Some(contact_point(&footprint(c.a)?, &footprint(c.b)?))
}

/// Where two colliding footprints meet: the centroid of their overlap, or
/// the midpoint of their centres when they only touch.
pub(in crate::record) fn contact_point(a: &OrientedBox, b: &OrientedBox) -> Point2 {
    overlap_centroid(a, b).unwrap_or_else(|| nalgebra::center(&a.pose.position, &b.pose.position))
}

pub(super) fn draw_trails(s: &mut String, pic: &Picture, view: &View, opts: &SvgOptions) {
    let n = pic.states.num_steps();
    let mut visible = view.bounds;
    visible.grow_to(view.bounds.width() + 20.0, view.bounds.height() + 20.0);
    if opts.all_trails {
        for (i, a) in pic.agents.iter().enumerate() {
            if a.role != Role::Other {
                continue;
            }
            for run in runs(pic, i, 0..n) {
                if run.len() >= 2 && Bounds::of_points(&run).intersects(&visible) {
                    let _ = writeln!(s, "<polyline class=\"trail\" points=\"{}\"/>", view.points(&run));
                }
            }
        }
    }
    // CBV first, ego on top: the ego's path is what the reviewer follows.
    for role in [Role::Cbv, Role::Ego] {
        for (i, a) in pic.agents.iter().enumerate().filter(|(_, a)| a.role == role) {
            let colour = role_colour(a.role);
            let class = role_class(a.role);
            let split = (pic.shown + 1).min(n);
            // The part after the displayed step starts at it, so the two parts join.
            for run in runs(pic, i, pic.shown.min(n)..n) {
                if run.len() >= 2 {
                    let _ = writeln!(
                        s,
                        "<polyline class=\"path after {class}\" stroke=\"{colour}\" points=\"{}\"/>",
                        view.points(&run)
                    );
                }
            }
            for run in runs(pic, i, 0..split) {
                if run.len() >= 2 {
                    let _ = writeln!(
                        s,
                        "<polyline class=\"path {class}\" stroke=\"{colour}\" points=\"{}\"/>",
                        view.points(&run)
                    );
                }
            }
            // A dot every second shows speed along the path.
            let every =
                if pic.dt_s.is_finite() && pic.dt_s > 0.0 { (1.0 / pic.dt_s).round().max(1.0) as usize } else { 10 };
            for k in (0..n).step_by(every) {
                if let Some(st) = pic.states.get(k, i) {
                    let (x, y) = view.px(&st.position);
                    let _ = writeln!(
                        s,
                        "<circle class=\"tick {class}\" fill=\"{colour}\" cx=\"{}\" cy=\"{}\" r=\"2\"/>",
                        N(x),
                        N(y)
                    );
                }
            }
        }
    }
}

pub(super) fn draw_extras(s: &mut String, pic: &Picture, view: &View) {
    let t_shown = pic.shown as f64 * pic.dt_s;
    for e in pic.extras {
        let colour = extra_colour(e);
        let pts: Vec<Point2> = e
            .poses
            .iter()
            .filter(|p| p.time_s.is_finite() && p.pose.heading_rad.is_finite())
            .map(|p| p.pose.position)
            .collect();
        if pts.len() >= 2 {
            let _ = writeln!(
                s,
                "<polyline class=\"extra\" stroke=\"{colour}\" points=\"{}\"><title>{}</title></polyline>",
                view.points(&pts),
                esc(&e.name)
            );
        }
        let Some(pose) = e.pose_at(t_shown) else { continue };
        match e.body.as_ref().and_then(|b| box_px(view, &pose, b)) {
            Some(b) => {
                let _ = writeln!(
                    s,
                    "<polygon class=\"ghost\" fill=\"{colour}\" stroke=\"{colour}\" points=\"{}\"/>",
                    b.outline
                );
            }
            None => {
                let (x, y) = view.px(&pose.position);
                let _ = writeln!(
                    s,
                    "<circle class=\"ghost\" fill=\"{colour}\" stroke=\"{colour}\" cx=\"{}\" cy=\"{}\" r=\"4\"/>",
                    N(x),
                    N(y)
                );
            }
        }
    }
}

/// Draws the footprints; returns their extents (for label placement) and
/// the labels they want, most important first.
pub(super) fn draw_agents(s: &mut String, pic: &Picture, view: &View) -> (Vec<Rect>, Vec<LabelRequest>) {
    let collided = collided(pic);
    // Others that hit the ego or CBV get their id; background collisions
    // only their red outline (a busy crosswalk would be unreadable).
    let hit_role: BTreeSet<usize> = pic
        .collisions
        .iter()
        .filter(|c| c.k <= pic.shown && (involves_role(pic, c.a) || involves_role(pic, c.b)))
        .flat_map(|c| [c.a, c.b])
        .collect();
    let mut extents = Vec::new();
    let mut role_labels = Vec::new();
    let mut other_labels = Vec::new();
    // Others first, then CBV, then ego, so the roles are never hidden.
    for role in [Role::Other, Role::Cbv, Role::Ego] {
        for (i, a) in pic.agents.iter().enumerate().filter(|(_, a)| a.role == role) {
            let Some(st) = pic.states.get(pic.shown, i) else { continue };
            let Some(b) = box_px(view, &st.pose(), &a.body) else { continue };
            let kind = kind_name(a.body.kind);
            let hit = collided.contains(&i);
            let class = match (role, hit) {
                (Role::Other, false) => format!("box {kind}"),
                (Role::Other, true) => format!("box {kind} collided"),
                (_, false) => format!("box {}", role_class(role)),
                (_, true) => format!("box {} collided", role_class(role)),
            };
            let head = match role {
                Role::Other => "#7a828c",
                _ => "#ffffff",
            };
            let _ = writeln!(
                s,
                "<g><title>{kind} {} ({:.1} m/s)</title><polygon class=\"{class}\" points=\"{}\"/>\
                 <polygon class=\"head\" fill=\"{head}\" points=\"{}\"/></g>",
                esc(a.id),
                st.speed_mps(),
                b.outline,
                b.head
            );
            extents.push(b.extent);
            let request = |text: &str, colour| LabelRequest { anchor: b.extent, text: text.to_string(), colour };
            match role {
                Role::Ego => role_labels.insert(0, request("ego", EGO)),
                Role::Cbv => role_labels.push(request("CBV", CBV)),
                Role::Other if hit_role.contains(&i) => other_labels.push(request(a.id, COLLISION)),
                Role::Other => {}
            }
        }
    }
    role_labels.extend(other_labels);
    (extents, role_labels)
}

/// Draws a marker at each collision up to the displayed step; returns the
/// markers' extents and the time labels of the ego's and CBV's collisions.
pub(super) fn draw_collisions(s: &mut String, pic: &Picture, view: &View) -> (Vec<Rect>, Vec<LabelRequest>) {
    let mut extents = Vec::new();
    let mut labels = Vec::new();
    for c in pic.collisions.iter().filter(|c| c.k <= pic.shown) {
        let Some(p) = collision_point(pic, c) else { continue };
        let (x, y) = view.px(&p);
        let main = involves_role(pic, c.a) || involves_role(pic, c.b);
        let (r, d) = if main { (9.0, 5.0) } else { (5.0, 3.0) };
        let _ = writeln!(
            s,
            "<g class=\"collision\"><title>collision of {} and {} at {}</title>\
             <circle class=\"marker\" cx=\"{}\" cy=\"{}\" r=\"{}\"/>\
             <path class=\"marker\" d=\"M{},{} L{},{} M{},{} L{},{}\"/></g>",
            esc(pic.agents.get(c.a).map_or("?", |a| a.id)),
            esc(pic.agents.get(c.b).map_or("?", |a| a.id)),
            time_text(c.k, pic.dt_s),
            N(x),
            N(y),
            N(r),
            N(x - d),
            N(y - d),
            N(x + d),
            N(y + d),
            N(x - d),
            N(y + d),
            N(x + d),
            N(y - d),
        );
        let extent = Rect { x0: x - r, y0: y - r, x1: x + r, y1: y + r };
        extents.push(extent);
        if main {
            labels.push(LabelRequest { anchor: extent, text: time_text(c.k, pic.dt_s), colour: COLLISION });
        }
    }
    (extents, labels)
}

//! Tests of the SVG pictures: crop, layers, labels, legend, determinism and
//! robustness to non-finite input, on the crossing fixtures of `record`.

use super::SvgOptions;
use super::agents::contact_point;
use super::canvas::focus;
use super::picture::{Agent, Picture, StateTable, role_of};
use crate::geometry::{OrientedBox, Pose2};
use crate::record::test_support::{crossing_rollout, crossing_scenario};
use crate::record::{NamedTrajectory, TimedPose, TrajectoryRole, render_rollout_svg, render_rollout_svg_with};
use crate::scenario::Scenario;

fn classes<'a>(doc: &'a roxmltree::Document) -> Vec<&'a str> {
    doc.descendants().filter_map(|n| n.attribute("class")).collect()
}

fn has_class(doc: &roxmltree::Document, wanted: &[&str]) -> bool {
    classes(doc).iter().any(|c| {
        let set: Vec<&str> = c.split_whitespace().collect();
        wanted.iter().all(|w| set.contains(w))
    })
}

fn texts(doc: &roxmltree::Document) -> String {
    doc.descendants().filter(|n| n.has_tag_name("text")).filter_map(|n| n.text()).collect::<Vec<_>>().join("\n")
}

#[test]
fn svg_of_a_collision_is_well_formed_and_marks_roles_and_the_collision() {
    let s = crossing_scenario();
    let r = crossing_rollout(&s);
    let c = r.ego_collision().expect("the fixture collides");
    assert_eq!(c.step, 39);
    let svg = render_rollout_svg(&s, &r, &SvgOptions::default());
    let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
    assert!(has_class(&doc, &["box", "ego", "collided"]), "ego outlined as collided");
    assert!(has_class(&doc, &["box", "cbv", "collided"]), "CBV outlined as collided");
    assert!(has_class(&doc, &["box", "vehicle"]) && has_class(&doc, &["box", "pedestrian"]));
    assert!(has_class(&doc, &["path", "ego"]) && has_class(&doc, &["path", "after", "cbv"]));
    assert!(has_class(&doc, &["collision"]) && has_class(&doc, &["marker"]), "collision marker");
    assert!(has_class(&doc, &["crosswalk"]) && has_class(&doc, &["edge"]) && has_class(&doc, &["lane"]));
    let t = texts(&doc);
    assert!(t.contains("crossing · planner constant-velocity"), "{t}");
    assert!(t.contains("collides with the CBV (cbv-2, vehicle) at t = 3.9 s"), "{t}");
    assert!(t.contains("ego (ego-1)") && t.contains("CBV (cbv-2)"), "legend names the roles: {t}");
    assert!(!svg.contains("NaN") && !svg.contains("-0.00"));
}

#[test]
fn svg_is_byte_identical_on_a_second_render() {
    let s = crossing_scenario();
    let r = crossing_rollout(&s);
    let a = render_rollout_svg(&s, &r, &SvgOptions::default());
    let b = render_rollout_svg(&s, &r, &SvgOptions::default());
    assert_eq!(a, b);
    assert_eq!(render_scenario_svg_default(&s), render_scenario_svg_default(&s));
}

fn render_scenario_svg_default(s: &Scenario) -> String {
    crate::record::render_scenario_svg(s, &SvgOptions::default())
}

#[test]
fn svg_crop_holds_every_ego_and_cbv_position_and_not_the_whole_map() {
    let s = crossing_scenario();
    let r = crossing_rollout(&s);
    let opts = SvgOptions::default();
    let pic_states = StateTable::Steps(&r.states);
    let pic = Picture {
        title: String::new(),
        map: &s.map,
        agents: r
            .bodies
            .iter()
            .enumerate()
            .map(|(i, b)| Agent { id: r.agent_ids[i].0.as_str(), body: *b, role: role_of(i, Some(r.ego), r.cbv) })
            .collect(),
        states: pic_states,
        dt_s: r.dt_s,
        shown: 10,
        collisions: vec![],
        extras: &[],
        caption: [String::new(), String::new()],
    };
    let b = focus(&pic, &opts);
    for st in r.states.iter().flat_map(|k| [k[0], k[1]]).flatten() {
        let p = st.position;
        assert!(p.x > b.lo.x && p.x < b.hi.x && p.y > b.lo.y && p.y < b.hi.y, "{p:?} outside {b:?}");
    }
    // The lanes span 200 m x 150 m; the crop follows the conflict.
    assert!(b.width() < 120.0 && b.height() < 120.0, "{b:?}");
    assert!(b.width() <= 2.0 * b.height() + 1e-9 && b.height() <= 2.0 * b.width() + 1e-9);
}

#[test]
fn svg_of_a_scenario_shows_the_current_step_without_collisions() {
    let s = crossing_scenario();
    let svg = crate::record::render_scenario_svg(&s, &SvgOptions { step: Some(20), ..SvgOptions::default() });
    let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
    assert!(has_class(&doc, &["box", "ego"]) && has_class(&doc, &["box", "cbv"]));
    assert!(!has_class(&doc, &["collided"]) && !has_class(&doc, &["collision"]));
    let t = texts(&doc);
    assert!(t.contains("shown: t = 2.0 s (step 20 of 60)"), "{t}");
    assert!(t.contains("ego ego-1 (named by the source)"), "{t}");
}

#[test]
fn svg_skips_non_finite_states_and_escapes_ids() {
    let mut s = crossing_scenario();
    s.id = "a<b&c\"d'".into();
    let mut r = crossing_rollout(&s);
    r.scenario_id = s.id.clone();
    r.agent_ids[2].0 = "<parked>".into();
    r.states[5][2].as_mut().unwrap().position.x = f64::NAN;
    r.states[39][3].as_mut().unwrap().heading_rad = f64::INFINITY;
    // A ragged row must not panic either.
    r.states[6].pop();
    let svg = render_rollout_svg(&s, &r, &SvgOptions::default());
    let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
    assert!(texts(&doc).contains("a<b&c\"d'"));
    assert!(!svg.contains("NaN") && !svg.contains("inf"));
    // The pedestrian has no finite state at the shown step: no box for it.
    assert!(!has_class(&doc, &["box", "pedestrian"]));
}

#[test]
fn svg_draws_a_feasibility_witness_and_its_footprint() {
    let s = crossing_scenario();
    let r = crossing_rollout(&s);
    // The ego braking to a stop before the crossing.
    let poses = (0..=60)
        .map(|k| {
            let t = 0.1 * k as f64;
            TimedPose { time_s: t, pose: Pose2::new((10.0 * t).min(30.0), -1.75, 0.0) }
        })
        .collect();
    let witness = NamedTrajectory {
        name: "brake".into(),
        role: TrajectoryRole::FeasibilityWitness,
        body: Some(r.bodies[0]),
        poses,
    };
    let svg = render_rollout_svg_with(&s, &r, &[witness], &SvgOptions::default());
    let doc = roxmltree::Document::parse(&svg).expect("well-formed XML");
    assert!(has_class(&doc, &["extra"]) && has_class(&doc, &["ghost"]));
    assert!(texts(&doc).contains("feasibility witness: brake"));
}

#[test]
fn contact_point_lies_in_the_overlap() {
    let a = OrientedBox::new(Pose2::new(0.0, 0.0, 0.0), 4.0, 2.0);
    let b = OrientedBox::new(Pose2::new(3.0, 0.0, 0.0), 4.0, 2.0);
    let p = contact_point(&a, &b);
    assert!((p.x - 1.5).abs() < 1e-9 && p.y.abs() < 1e-9, "{p:?}");
    // Apart: the midpoint of the centres.
    let c = OrientedBox::new(Pose2::new(10.0, 0.0, 0.0), 4.0, 2.0);
    assert!((contact_point(&a, &c).x - 5.0).abs() < 1e-9);
}

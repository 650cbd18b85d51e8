//! The traffic a witness must avoid ([`FixedTraffic`]): every other
//! agent's states per step, fixed as the variant drove them, with their
//! bodies, and the boxes they put in the ego's way at each step.

use super::road_cells::RoadRule;
use crate::geometry::{BoxSet, OrientedBox, Point2};
use crate::scenario::{AgentBody, AgentState};

/// The obstacles: every other agent's state per simulator step from the start
/// (`obstacles[k]` = the agents at step k), with their bodies.
#[derive(Debug, Clone, Copy)]
pub struct FixedTraffic<'a> {
    /// `states[k][i]`: agent i at step k (`None` = absent).
    pub states: &'a [Vec<Option<AgentState>>],
    /// Bodies, same indexing.
    pub bodies: &'a [AgentBody],
    /// The ego's index in `states` (ignored as an obstacle).
    pub ego: usize,
    /// The road the ego must keep to (`None`: it may drive anywhere, as
    /// for V_h's labels: V_h sees no map either).
    pub road: Option<RoadRule<'a>>,
}

impl FixedTraffic<'_> {
    /// The other agents' boxes at `step`, less those whose centre lies
    /// farther than `keep_within_m` (plus the box's bounding radius) from
    /// `around`.
    pub(super) fn obstacles_at(&self, step: usize, around: &Point2, keep_within_m: f64) -> BoxSet {
        let row = self.states.get(step).map_or(&[][..], Vec::as_slice);
        BoxSet::new(row.iter().enumerate().filter(|(i, _)| *i != self.ego).filter_map(|(i, s)| {
            let b = self.bodies[i];
            let s = s.as_ref()?;
            let far = (s.position - around).norm() > keep_within_m + 0.5 * b.length_m.hypot(b.width_m);
            (!far).then(|| OrientedBox::new(s.pose(), b.length_m, b.width_m))
        }))
    }
}

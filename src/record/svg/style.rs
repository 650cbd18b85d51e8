//! The look of a picture: the embedded stylesheet and the colours of the
//! roles (ego blue and CBV orange, distinguishable for the common
//! colour-vision deficiencies; red for collisions only) and of extra
//! trajectories.

use super::picture::Role;
use crate::record::{NamedTrajectory, TrajectoryRole};

// Colours: ego blue and CBV orange are distinguishable for the common
// colour-vision deficiencies; red is kept for collisions only.
/// The ego.
pub(super) const EGO: &str = "#1f6fd1";
/// The CBV.
pub(super) const CBV: &str = "#ef8a00";
/// Collisions only.
pub(super) const COLLISION: &str = "#d62728";
/// A feasibility witness.
pub(super) const WITNESS: &str = "#1a9850";
/// The ego's plan.
pub(super) const PLAN: &str = "#7b3294";
/// A reference trajectory.
pub(super) const REFERENCE: &str = "#5a5a5a";

/// The stylesheet every picture embeds.
pub(super) const STYLE: &str = "\
.bg{fill:#ffffff}\
.drivable{fill:#eef1f5;stroke:none}\
.crosswalk{fill:url(#hatch);stroke:#b4b4b4;stroke-width:0.8}\
.bump{fill:#f3dfc1;stroke:none}\
.driveway{fill:#f1f1f1;stroke:#dddddd;stroke-width:0.6}\
.lane{fill:none;stroke:#a9bdd3;stroke-width:1;stroke-dasharray:6 4}\
.line{fill:none;stroke:#9a9a9a;stroke-width:1.1}\
.line.yellow{stroke:#d9a400}\
.line.broken{stroke-dasharray:5 5}\
.edge{fill:none;stroke:#3b3b3b;stroke-width:1.8;stroke-linejoin:round}\
.stop{fill:#c0392b;stroke:#ffffff;stroke-width:0.8}\
.trail{fill:none;stroke:#7d8791;stroke-width:1;stroke-opacity:0.45}\
.path{fill:none;stroke-width:2.6;stroke-linejoin:round;stroke-linecap:round}\
.path.after{stroke-width:1.6;stroke-dasharray:5 4;stroke-opacity:0.7}\
.tick{stroke:none}\
.box{stroke-width:1.1;stroke-linejoin:round}\
.box.vehicle{fill:#c3c8ce;stroke:#59616b}\
.box.pedestrian{fill:#cdb9e8;stroke:#5f4596}\
.box.cyclist{fill:#a8dcc8;stroke:#23795c}\
.box.other{fill:#dedbd2;stroke:#7a7568}\
.head{stroke:none}\
.box.ego{fill:#1f6fd1;stroke:#0b3a78;stroke-width:1.6}\
.box.cbv{fill:#ef8a00;stroke:#8a4f00;stroke-width:1.6}\
.box.collided{stroke:#d62728;stroke-width:3}\
.ghost{fill-opacity:0.12;stroke-width:1.6;stroke-dasharray:4 3}\
.extra{fill:none;stroke-width:2.2;stroke-dasharray:7 4;stroke-linecap:round}\
.marker{fill:#ffffff;fill-opacity:0.8;stroke:#d62728;stroke-width:2.4}\
.label{font-size:13px;font-weight:bold;paint-order:stroke;stroke:#ffffff;stroke-width:3.5px;stroke-linejoin:round}\
.caption{font-size:15px;font-weight:bold;fill:#1b1b1b}\
.sub{font-size:13px;fill:#333333}\
.legend{font-size:12px;fill:#333333}\
.scale{stroke:#222222;stroke-width:1.6;fill:none}\
.band{fill:#f7f7f7;stroke:#d0d0d0;stroke-width:1}";

/// The colour of an extra trajectory, by its role.
pub(super) fn extra_colour(e: &NamedTrajectory) -> &'static str {
    match e.role {
        TrajectoryRole::FeasibilityWitness => WITNESS,
        TrajectoryRole::EgoPlan => PLAN,
        TrajectoryRole::Reference => REFERENCE,
    }
}

/// The CSS class of a role.
pub(super) fn role_class(role: Role) -> &'static str {
    match role {
        Role::Ego => "ego",
        Role::Cbv => "cbv",
        Role::Other => "other",
    }
}

/// The colour of a role.
pub(super) fn role_colour(role: Role) -> &'static str {
    match role {
        Role::Ego => EGO,
        Role::Cbv => CBV,
        Role::Other => "#7d8791",
    }
}

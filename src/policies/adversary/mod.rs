//! The SaFeR adversary: drives the critical background vehicle (CBV) token
//! by token. Every token period it takes the realism prior's top-n tokens
//! (the trust region, which keeps the behaviour human-like), predicts the
//! CBV's state after each through the kinematic model, and picks the token
//! with the least loss: the box distance to the ego when the feasibility
//! value says the ego can still avoid a collision (V_h ≤ 0), else V_h + Δ
//! (so an unavoidable state is chosen only when nothing else is left). The
//! choice is the paper's strict arg min, ties broken by the prior's logit
//! and then the token id, so it is a pure function of the world.
//!
//! Two things the paper leaves open are fixed here:
//! - **Seeds.** With the background on log replay an arg min gives every
//!   seed the same variant. The seed instead sets an *approach phase*: the
//!   prior samples the CBV's first 1–4 tokens (0.5–2 s, drawn from the
//!   seed) before the adversary engages, so each seed starts the attack
//!   from a different, realistic state.
//! - **Plausibility.** The CBV must stay a plausible road user. A
//!   candidate is implausible when its 0.5 s rollout takes the CBV from the
//!   road onto the off-road area (or, off the road already, farther from
//!   it; driving on past the mapped end of the road, where the recording's
//!   map was cut off, is not leaving it), when a background agent
//!   (replayed agents where their recording puts them, the others at
//!   constant velocity: [`BackgroundForecast`]) and the CBV touch during
//!   the token or the second after it with the token held (no brake checks
//!   on followers, no stopping in the way of crossing traffic), when a
//!   replayed agent would run into the CBV in the 2 s after that with the
//!   CBV keeping its speed (replay cannot yield: no slowing down in front
//!   of traffic closing fast), when it turns the CBV harder than a car's
//!   tyres hold (more than 9 m/s² sideways, the ego's own default limit)
//!   or tighter than a car steers (beyond the paper, see `turning_limit`), or when
//!   the CBV, braking as hard as it can after the token (holding its
//!   curvature, as a driver braking in a bend does), would leave the road
//!   before it stands, or run into one within 2 s (at fault as the
//!   metrics judge it: a follower running into a braking CBV is not the
//!   CBV's doing). A plausible token leaves the CBV room to stop on the
//!   road. The arg min
//!   is taken over the plausible candidates of the trust region; when none
//!   is plausible the CBV takes the likeliest plausible token of the whole
//!   vocabulary (what a careful driver would do: the trust region is for
//!   realism, and leaving the road or hitting traffic is not realistic).
//!   When no token at all is plausible, a replayed agent is about to run
//!   into the CBV whatever it does (replay cannot yield); then the same
//!   two steps are taken with only the contacts the CBV would be at fault
//!   for counted (and cut-ins: hit from behind in a lane it moved into,
//!   which nuPlan's rule does not blame): waiting to be hit is better than
//!   fleeing into someone else. Only when even that leaves nothing, the
//!   trust region's token within grip that breaks the rule latest (a car
//!   can break a rule, not its tyres' limit). The same rule restricts the
//!   prior's draws in the approach phase, which are held within grip even
//!   where nothing is plausible.
//!
//! The ablations are the same policy with a part switched off;
//! `safer-lookahead` (beyond the paper) is the same policy scoring tokens
//! over a receding horizon (see [`Search::lookahead_tokens`]);
//! `safer-in-path` (beyond the paper) the same policy over the prior's
//! distinct behaviours, scoring how close a token puts the CBV to the
//! ego's path ahead of it rather than to the ego (see [`Objective`]);
//! `safer-cut-in` (beyond the paper) the same as `safer-in-path` with a
//! loss that draws the CBV ahead of the ego and all the way into its path;
//! `safer-in-path-lookahead` (beyond the paper) `safer-in-path` scored
//! over the receding horizon of `safer-lookahead`;
//! `safer-inattentive` (beyond the paper) the same policy fed by a prior
//! that does not see the ego (see
//! [`PriorTraffic::hide_from`](crate::policies::prior_sampling::PriorTraffic::hide_from)).
//! Any SaFeR method may be kept from contacts from behind the ego and
//! off its bumper (beyond the paper; see [`EgoContactRule`]), and from driving against a lane's
//! traffic (beyond the paper; see [`WrongWayRule`]); and any may weigh
//! how hard a token turns the CBV in its loss (beyond the paper; see
//! [`CbvTurningCost`]).
//! Any method with V_h may also ask, near the ego, whether the traffic
//! around the ego leaves it room to escape, or whether the feasibility
//! witness finds it an escape (beyond the paper; see [`FeasibilityScope`]).
//!
//! One file per concept: the [`Adversary`] policy (`policy`), the
//! approach phase (`approach`), SaFeR's choice ([`safer_choice`],
//! `choice`) and the lookahead of `safer-lookahead` (`lookahead`), V_h of
//! candidate states (`feasibility`), the tyres' grip and a car's turning circle (`turning_limit`), the ego's room to escape among the traffic (`escape_room`), which contacts with the ego it may make (`ego_contact`), whether it may drive against the traffic (`wrong_way`) and the witness asked before a contact (`contact_witness`), what a candidate's loss measures (`objective`) with the in-path and cut-in losses (`in_path`) and what a turn adds to it (`turning_cost`), the CBV's states under a token
//! (`rollout`), the [`BackgroundForecast`], and the plausibility check
//! (`plausibility`, with its broad phase in `broad_phase`), how late it sees
//! the ego (`reaction`); and the
//! [`TrustRegionProfile`] that diagnoses what a prior's region offers
//! (`trust_region_profile`).

mod approach;
mod background_forecast;
mod behaviours;
mod broad_phase;
mod choice;
mod contact_witness;
mod continuations;
mod ego_contact;
mod escape_room;
mod feasibility;
mod in_path;
mod lane_change_pace;
mod lookahead;
mod objective;
mod plausibility;
mod policy;
mod reaction;
mod rollout;
#[cfg(test)]
mod test_support;
mod trust_region_profile;
mod turning_cost;
mod turning_limit;
mod wrong_way;

pub use crate::models::feasibility_oracle::{EgoCbvState, FeasibilityOracle};
pub use approach::{APPROACH_TOKENS, ApproachPhase};
pub use background_forecast::BackgroundForecast;
pub use behaviours::{BEHAVIOUR_HOLD_S, BEHAVIOUR_SEPARATION_M, distinct_behaviours};
pub use choice::{Feasibility, INFEASIBLE_PENALTY, Search, TrustRegion, safer_choice};
pub use contact_witness::{EscapeWitness, WITNESS_CHECK_GAP_M, WITNESS_CHECKS_PER_TOKEN};
pub use ego_contact::{EgoContactRule, TAIL_BRAKE_MPS2};
pub use escape_room::{
    ESCAPE_ACCELS_MPS2, ESCAPE_CHECK_GAP_M, ESCAPE_HORIZON_S, ESCAPE_PURSUIT_MPS2, ESCAPE_YAW_RATES_RADPS,
    FeasibilityScope, NO_ROOM_VALUE,
};
pub use in_path::{
    CUT_IN_LATERAL_COST, CUT_IN_NOT_AHEAD_COST, IN_PATH_LEAD_COST_M_PER_S, IN_PATH_MAX_LEAD_S, NOT_AHEAD_PENALTY_M,
};
pub use lane_change_pace::HUMAN_LANE_CHANGE_MAX_SIDEWAYS_MPS;
pub use lookahead::{LOOKAHEAD_DELAY_PENALTY_M, LOOKAHEAD_TOKENS};
pub use objective::Objective;
pub use policy::Adversary;
pub use reaction::{EgoSight, REACTION_TIME_S};
pub use trust_region_profile::{TrustRegionProfile, profile_trust_region, rank_of_driven_token};
pub use turning_cost::{CbvTurningCost, MAX_TURNING_COST_M_PER_MPS2};
pub use turning_limit::CbvTurningLimit;
pub use wrong_way::WrongWayRule;

//! The feasibility value V_h (the Largest Feasible Region of FREA): features
//! of an ego–CBV state, the constraint indicator h, and the shipped ONNX
//! model that answers a batch of up to [`FEASIBILITY_BATCH`] states per call
//! (the adversary asks for its 20 candidates at once). The same feature code
//! writes the training transitions and feeds inference.
//!
//! V_h(s) ≤ 0 means the ego can still keep the CBV out of the d_th box
//! distance; V_h > 0 means it cannot (the CBV state is outside the region).

use tract_onnx::prelude::*;

use super::card::{DType, ExpectedContract, ModelKind};
use super::feasibility_oracle::{EgoCbvState, FeasibilityOracle};
use super::onnx::{OnnxModel, f32_values};
use super::{ModelError, ModelSource};
use crate::geometry::{OrientedBox, Pose2, Vector2, wrap_angle};
use crate::scenario::{AgentBody, AgentState};

/// Values per feasibility state.
pub const FEASIBILITY_FEATURES: usize = 13;
/// States per model call.
pub const FEASIBILITY_BATCH: usize = 20;
/// Box distance under which a state violates the constraint, m (d_th).
pub const DISTANCE_THRESHOLD_M: f64 = 0.3;
/// h of a violating state (M).
pub const VIOLATION_COST: f64 = 16.0;
/// h of a safe state.
pub const SAFE_COST: f64 = -1.0;
/// Model file stem in `models/`.
pub const FEASIBILITY_MODEL: &str = "feasibility-value";

/// The constraint indicator h(s) from the ego–CBV box distance.
pub fn constraint_cost(box_distance_m: f64) -> f64 {
    if box_distance_m > DISTANCE_THRESHOLD_M { SAFE_COST } else { VIOLATION_COST }
}

/// Box distance between ego and CBV (0 when they overlap), m.
pub fn box_distance_m(pair: &EgoCbvState) -> f64 {
    let e = OrientedBox::new(pair.ego.pose(), pair.ego_body.length_m, pair.ego_body.width_m);
    let c = OrientedBox::new(pair.cbv.pose(), pair.cbv_body.length_m, pair.cbv_body.width_m);
    if e.intersects(&c) { 0.0 } else { e.distance(&c) }
}

/// The features of an ego–CBV state, in the ego's frame: CBV centre x, y
/// (m), cos and sin of the relative heading, ego speed, CBV speed (m/s),
/// CBV velocity in the ego frame vx, vy (m/s), ego length and width, CBV
/// length and width (m), box distance (m). The box distance is a function
/// of the rest, but giving it directly makes the constraint boundary
/// (d_th = 0.3 m) easy to learn for a small network.
pub fn feasibility_features(pair: &EgoCbvState) -> [f32; FEASIBILITY_FEATURES] {
    let frame = Pose2 { position: pair.ego.position, heading_rad: pair.ego.heading_rad };
    let p = frame.to_body(&pair.cbv.position);
    let (s, c) = pair.ego.heading_rad.sin_cos();
    let v = pair.cbv.velocity_mps;
    let v_ego_frame = Vector2::new(c * v.x + s * v.y, -s * v.x + c * v.y);
    let dh = wrap_angle(pair.cbv.heading_rad - pair.ego.heading_rad);
    [
        p.x as f32,
        p.y as f32,
        dh.cos() as f32,
        dh.sin() as f32,
        pair.ego.speed_mps() as f32,
        pair.cbv.speed_mps() as f32,
        v_ego_frame.x as f32,
        v_ego_frame.y as f32,
        pair.ego_body.length_m as f32,
        pair.ego_body.width_m as f32,
        pair.cbv_body.length_m as f32,
        pair.cbv_body.width_m as f32,
        box_distance_m(pair) as f32,
    ]
}

/// The pair from two agent states and bodies.
pub fn pair(ego: AgentState, ego_body: AgentBody, cbv: AgentState, cbv_body: AgentBody) -> EgoCbvState {
    EgoCbvState { ego, ego_body, cbv, cbv_body }
}

/// What this build expects of the feasibility model.
pub fn feasibility_contract() -> ExpectedContract {
    ExpectedContract {
        kind: ModelKind::FeasibilityValue,
        inputs: vec![("state", DType::F32, vec![Some(FEASIBILITY_BATCH), Some(FEASIBILITY_FEATURES)])],
        outputs: vec![("value", DType::F32, vec![Some(FEASIBILITY_BATCH), Some(1)])],
        speaks_tokens: false,
    }
}

/// The shipped V_h.
#[derive(Debug, Clone)]
pub struct FeasibilityValue {
    model: OnnxModel,
}

impl FeasibilityValue {
    /// Loads `feasibility-value` from `source`, checked against its card.
    pub fn load(source: &ModelSource) -> Result<Self, ModelError> {
        let card = format!("{FEASIBILITY_MODEL}.card.yaml");
        Ok(Self { model: OnnxModel::load(source, card, &feasibility_contract(), FEASIBILITY_BATCH)? })
    }

    /// The underlying model (for golden replay).
    pub fn model(&self) -> &OnnxModel {
        &self.model
    }

    /// V_h of each state, in batches of [`FEASIBILITY_BATCH`] (the last one padded).
    pub fn evaluate(&self, pairs: &[EgoCbvState]) -> Result<Vec<f32>, ModelError> {
        let mut out = Vec::with_capacity(pairs.len());
        for chunk in pairs.chunks(FEASIBILITY_BATCH) {
            let mut input = vec![0.0f32; FEASIBILITY_BATCH * FEASIBILITY_FEATURES];
            for (i, p) in chunk.iter().enumerate() {
                input[i * FEASIBILITY_FEATURES..(i + 1) * FEASIBILITY_FEATURES]
                    .copy_from_slice(&feasibility_features(p));
            }
            let err = |e: TractError| ModelError::Input { model: FEASIBILITY_MODEL.into(), message: format!("{e:#}") };
            let t = Tensor::from_shape(&[FEASIBILITY_BATCH, FEASIBILITY_FEATURES], &input).map_err(err)?;
            let result = self.model.run(tvec!(t.into_tvalue()))?;
            let values = f32_values(&result[0]).map_err(err)?;
            out.extend_from_slice(&values[..chunk.len()]);
        }
        Ok(out)
    }
}

impl FeasibilityOracle for FeasibilityValue {
    fn values(&self, pairs: &[EgoCbvState]) -> Result<Vec<f32>, ModelError> {
        self.evaluate(pairs)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::Point2;
    use crate::scenario::AgentKind;

    fn car() -> AgentBody {
        AgentBody { kind: AgentKind::Vehicle, length_m: 4.0, width_m: 2.0 }
    }

    #[test]
    fn features_are_in_the_ego_frame() {
        let h = std::f64::consts::FRAC_PI_2;
        let ego = AgentState { position: Point2::new(0.0, 0.0), heading_rad: h, velocity_mps: Vector2::new(0.0, 5.0) };
        // CBV 10 m ahead of the ego (north), coming towards it at 3 m/s.
        let cbv =
            AgentState { position: Point2::new(0.0, 10.0), heading_rad: -h, velocity_mps: Vector2::new(0.0, -3.0) };
        let f = feasibility_features(&pair(ego, car(), cbv, car()));
        assert!((f[0] - 10.0).abs() < 1e-5 && f[1].abs() < 1e-5);
        assert!((f[2] + 1.0).abs() < 1e-6);
        assert!((f[4] - 5.0).abs() < 1e-6 && (f[5] - 3.0).abs() < 1e-6);
        assert!((f[6] + 3.0).abs() < 1e-5 && f[7].abs() < 1e-5);
        assert!((f[12] - 6.0).abs() < 1e-4, "box distance {}", f[12]);
    }

    #[test]
    fn the_constraint_cost_switches_at_the_threshold() {
        assert_eq!(constraint_cost(0.31), SAFE_COST);
        assert_eq!(constraint_cost(0.3), VIOLATION_COST);
        assert_eq!(constraint_cost(0.0), VIOLATION_COST);
    }

    /// The lookahead asks V_h of whichever continuations its search needs,
    /// in batches of any make-up, and relies on this: a state's value is
    /// the same bits alone, in any place of a batch and beside any others.
    #[test]
    fn a_state_is_valued_the_same_whatever_its_batch() {
        let v = FeasibilityValue::load(&ModelSource::shipped()).unwrap();
        let pairs: Vec<EgoCbvState> = (0..45)
            .map(|k| {
                let k = k as f64;
                let ego = AgentState {
                    position: Point2::new(0.0, 0.0),
                    heading_rad: 0.1 * k,
                    velocity_mps: Vector2::new(8.0 + 0.3 * k, 0.2 * k),
                };
                let cbv = AgentState {
                    position: Point2::new(3.0 + 0.7 * k, -4.0 + 0.4 * k),
                    heading_rad: -0.05 * k,
                    velocity_mps: Vector2::new(12.0 - 0.2 * k, 0.0),
                };
                EgoCbvState { ego, cbv, ego_body: car(), cbv_body: car() }
            })
            .collect();
        let alone: Vec<u32> = pairs.iter().map(|p| v.evaluate(std::slice::from_ref(p)).unwrap()[0].to_bits()).collect();
        let together: Vec<u32> = v.evaluate(&pairs).unwrap().iter().map(|x| x.to_bits()).collect();
        assert_eq!(together, alone);
        let mut shifted = pairs.clone();
        shifted.rotate_left(7);
        let shifted: Vec<u32> = v.evaluate(&shifted).unwrap().iter().map(|x| x.to_bits()).collect();
        for (i, bits) in shifted.iter().enumerate() {
            assert_eq!(*bits, alone[(i + 7) % pairs.len()], "row {i}");
        }
        assert_ne!(alone[0], alone[1]);
    }
}

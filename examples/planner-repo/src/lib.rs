//! A cautious cruise planner: it follows a reference path with pure
//! pursuit and keeps its speed with the Intelligent Driver Model behind the
//! nearest road user in its corridor. It knows nothing of safer: its inputs
//! and outputs are its own plain types, and the test target adapts them.

/// A point in the planner's frame, metres.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Point {
    /// x, m.
    pub x: f64,
    /// y, m.
    pub y: f64,
}

/// The ego's state.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EgoState {
    /// Centre of the vehicle.
    pub position: Point,
    /// Heading, rad.
    pub heading_rad: f64,
    /// Speed, m/s.
    pub speed_mps: f64,
    /// Length, m.
    pub length_m: f64,
}

/// Another road user.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RoadUser {
    /// Centre.
    pub position: Point,
    /// Heading, rad.
    pub heading_rad: f64,
    /// Speed along its heading, m/s.
    pub speed_mps: f64,
    /// Length, m.
    pub length_m: f64,
    /// Width, m.
    pub width_m: f64,
}

/// What the planner sees at one step.
#[derive(Debug, Clone, PartialEq)]
pub struct Scene {
    /// The ego.
    pub ego: EgoState,
    /// The path to follow, starting near the ego, in driving order.
    pub reference_path: Vec<Point>,
    /// Speed limit where known, m/s.
    pub speed_limit_mps: Option<f64>,
    /// Everyone else.
    pub others: Vec<RoadUser>,
}

/// The command for the next step.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Command {
    /// Longitudinal acceleration, m/s².
    pub accel_mps2: f64,
    /// Yaw rate, rad/s.
    pub yaw_rate_radps: f64,
}

/// The planner's tuning.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CautiousCruiser {
    /// Cruise speed when the map gives no limit, m/s.
    pub cruise_mps: f64,
    /// Desired time headway, s.
    pub headway_s: f64,
    /// Standstill gap, m.
    pub min_gap_m: f64,
    /// Comfortable acceleration, m/s².
    pub accel_mps2: f64,
    /// Comfortable braking, m/s².
    pub comfort_brake_mps2: f64,
    /// Hardest braking, m/s².
    pub max_brake_mps2: f64,
    /// Half-width of the corridor searched for a leader, m.
    pub corridor_half_width_m: f64,
    /// How far ahead a road user's lateral motion is followed when judging
    /// whether it cuts into the corridor, s.
    pub cut_in_lookahead_s: f64,
}

impl Default for CautiousCruiser {
    fn default() -> Self {
        Self {
            cruise_mps: 25.0,
            headway_s: 1.6,
            min_gap_m: 3.0,
            accel_mps2: 1.5,
            comfort_brake_mps2: 2.5,
            max_brake_mps2: 8.0,
            corridor_half_width_m: 1.8,
            cut_in_lookahead_s: 1.0,
        }
    }
}

impl CautiousCruiser {
    /// The command for `scene`.
    pub fn plan(&self, scene: &Scene) -> Command {
        let ego = &scene.ego;
        let desired = scene.speed_limit_mps.unwrap_or(self.cruise_mps).max(1.0);
        let free = 1.0 - (ego.speed_mps / desired).powi(4);
        let mut accel = self.accel_mps2 * free;
        if let Some((gap_m, leader_mps)) = self.leader(scene) {
            let closing = ego.speed_mps - leader_mps;
            let wanted = self.min_gap_m
                + (ego.speed_mps * self.headway_s
                    + ego.speed_mps * closing / (2.0 * (self.accel_mps2 * self.comfort_brake_mps2).sqrt()))
                .max(0.0);
            accel = self.accel_mps2 * (free - (wanted / gap_m.max(0.1)).powi(2));
        }
        Command {
            accel_mps2: accel.clamp(-self.max_brake_mps2, self.accel_mps2),
            yaw_rate_radps: pure_pursuit(ego, &scene.reference_path),
        }
    }

    /// Bumper-to-bumper gap and speed of the nearest road user ahead in the
    /// corridor along the reference path.
    fn leader(&self, scene: &Scene) -> Option<(f64, f64)> {
        if cfg!(feature = "regression") {
            // The regression the example's red CI run shows: no leader, no braking.
            return None;
        }
        let ego = &scene.ego;
        let (c, s) = (ego.heading_rad.cos(), ego.heading_rad.sin());
        scene
            .others
            .iter()
            .filter_map(|o| {
                let (dx, dy) = (o.position.x - ego.position.x, o.position.y - ego.position.y);
                let ahead = dx * c + dy * s;
                let lateral = -dx * s + dy * c;
                // A road user cutting in counts before it is in the lane:
                // where it will be in `cut_in_lookahead_s`, at its speed and
                // heading, relative to where the ego will be.
                let t = self.cut_in_lookahead_s;
                let (vx, vy) = (o.speed_mps * o.heading_rad.cos(), o.speed_mps * o.heading_rad.sin());
                let lateral_then = -(dx + (vx - ego.speed_mps * c) * t) * s + (dy + (vy - ego.speed_mps * s) * t) * c;
                let reach = self.corridor_half_width_m + o.width_m / 2.0;
                let in_corridor = lateral.abs() < reach || lateral_then.abs() < reach;
                let gap = ahead - (ego.length_m + o.length_m) / 2.0;
                (ahead > 0.0 && in_corridor).then_some((gap, o.speed_mps))
            })
            .min_by(|a, b| a.0.total_cmp(&b.0))
    }
}

/// Yaw rate that steers towards the path point one lookahead ahead.
fn pure_pursuit(ego: &EgoState, path: &[Point]) -> f64 {
    let lookahead = (ego.speed_mps * 1.2).clamp(6.0, 30.0);
    let Some(target) =
        path.iter().find(|p| ((p.x - ego.position.x).powi(2) + (p.y - ego.position.y).powi(2)).sqrt() >= lookahead)
    else {
        return 0.0;
    };
    let (dx, dy) = (target.x - ego.position.x, target.y - ego.position.y);
    let alpha = dy.atan2(dx) - ego.heading_rad;
    let alpha = alpha.sin().atan2(alpha.cos());
    let distance = (dx * dx + dy * dy).sqrt();
    (2.0 * ego.speed_mps * alpha.sin() / distance).clamp(-0.6, 0.6)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ego(speed: f64) -> EgoState {
        EgoState { position: Point { x: 0.0, y: 0.0 }, heading_rad: 0.0, speed_mps: speed, length_m: 4.5 }
    }

    fn straight() -> Vec<Point> {
        (0..50).map(|i| Point { x: i as f64 * 2.0, y: 0.0 }).collect()
    }

    #[test]
    #[cfg_attr(feature = "regression", ignore = "the regression build ignores leaders on purpose")]
    fn brakes_hard_for_a_stopped_car_close_ahead() {
        let stopped = RoadUser {
            position: Point { x: 15.0, y: 0.0 },
            heading_rad: 0.0,
            speed_mps: 0.0,
            length_m: 4.5,
            width_m: 1.9,
        };
        let scene = Scene { ego: ego(20.0), reference_path: straight(), speed_limit_mps: None, others: vec![stopped] };
        assert!(CautiousCruiser::default().plan(&scene).accel_mps2 <= -7.9);
    }

    #[test]
    #[cfg_attr(feature = "regression", ignore = "the regression build ignores leaders on purpose")]
    fn brakes_for_a_car_cutting_in_before_it_is_in_the_lane() {
        // 3.5 m to the left, 12 m ahead, angled 15° into the ego's lane.
        let cutting_in = RoadUser {
            position: Point { x: 12.0, y: 3.5 },
            heading_rad: -0.26,
            speed_mps: 12.0,
            length_m: 4.5,
            width_m: 1.9,
        };
        let scene =
            Scene { ego: ego(20.0), reference_path: straight(), speed_limit_mps: None, others: vec![cutting_in] };
        assert!(CautiousCruiser::default().plan(&scene).accel_mps2 < -2.0);
        // Going straight on in its own lane, it is no leader.
        let beside = RoadUser { heading_rad: 0.0, ..cutting_in };
        let scene = Scene { others: vec![beside], ..scene };
        assert!(CautiousCruiser::default().plan(&scene).accel_mps2 > 0.0);
    }

    #[test]
    fn accelerates_on_an_empty_road_and_steers_back_to_the_path() {
        let mut e = ego(10.0);
        e.position.y = 1.0;
        let scene = Scene { ego: e, reference_path: straight(), speed_limit_mps: Some(25.0), others: vec![] };
        let command = CautiousCruiser::default().plan(&scene);
        assert!(command.accel_mps2 > 1.0 && command.yaw_rate_radps < 0.0, "{command:?}");
    }
}
